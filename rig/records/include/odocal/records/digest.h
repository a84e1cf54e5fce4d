// The content digest that keys a record: SHA-256 (OpenSSL) over what the run measured, so that
// processing the same recordings again finds the record it already made.
#ifndef ODOCAL_RECORDS_DIGEST_H_
#define ODOCAL_RECORDS_DIGEST_H_

#include <string>
#include <vector>

#include "odocal/base/status.h"

namespace odocal::records {

// sha256 (lower-case hex) over `label` and then, for each file in the order given, its name
// (without the directory: a session copied elsewhere is the same session) and its bytes. A
// file that cannot be read is an error naming it.
Result<std::string> DigestFiles(const std::string& label, const std::vector<std::string>& files);
// sha256 (lower-case hex) of `text`.
std::string DigestText(const std::string& text);

}  // namespace odocal::records

#endif  // ODOCAL_RECORDS_DIGEST_H_
