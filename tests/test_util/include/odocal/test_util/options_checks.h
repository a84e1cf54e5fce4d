// IsValid tests of options structs, table-driven: a valid value (the defaults, for an options
// struct) passes, and each edit of it fails with a `why` that says what is wrong.
#ifndef ODOCAL_TEST_UTIL_OPTIONS_CHECKS_H_
#define ODOCAL_TEST_UTIL_OPTIONS_CHECKS_H_

#include <functional>
#include <string>
#include <utility>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace odocal::test_util {

// An edit that makes a valid value invalid, and the words `why` must then hold (the field's
// name where IsValid names it).
template <typename T>
using BadEdit = std::pair<std::function<void(T*)>, std::string>;

// `valid` passes IsValid; each edit of a copy of it fails, with `why` holding the edit's words
// (and without a `why` to fill: IsValid(nullptr) is allowed).
template <typename T>
void ExpectValidAndEachEditRejected(const T& valid, const std::vector<BadEdit<T>>& edits) {
  std::string why;
  EXPECT_TRUE(valid.IsValid(&why)) << "the unedited value: " << why;
  EXPECT_TRUE(valid.IsValid(nullptr));
  for (size_t i = 0; i < edits.size(); ++i) {
    T bad = valid;
    edits[i].first(&bad);
    why.clear();
    EXPECT_FALSE(bad.IsValid(&why)) << "edit " << i << " (" << edits[i].second << ") passes";
    EXPECT_FALSE(bad.IsValid(nullptr)) << "edit " << i << " (" << edits[i].second << ") without a why";
    EXPECT_FALSE(why.empty()) << "edit " << i << " gives no reason";
    EXPECT_THAT(why, ::testing::HasSubstr(edits[i].second)) << "edit " << i;
  }
}

}  // namespace odocal::test_util

#endif  // ODOCAL_TEST_UTIL_OPTIONS_CHECKS_H_
