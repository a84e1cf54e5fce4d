#include "odocal/calibration/run_flag.h"

#include <optional>
#include <sstream>
#include <string>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

namespace odocal::calibration {
namespace {

// Every kind with its documented name and fatality (run_flag.h: "fatal" in
// the enum's comments), written out independently of the source's table.
struct KindCase {
  RunFlagKind kind;
  const char* name;
  bool fatal;
  bool message_detail;  // the detail is a message: ": " before it
};

const KindCase kCases[] = {
    {RunFlagKind::kVideoUnreadable, "video_unreadable", true, true},
    {RunFlagKind::kTimestampsUnreadable, "timestamps_unreadable", false, false},
    {RunFlagKind::kTelemetryUnreadable, "telemetry_unreadable", false, true},
    {RunFlagKind::kTelemetryMalformed, "telemetry_malformed", false, true},
    {RunFlagKind::kNoTelemetry, "no_telemetry", false, false},
    {RunFlagKind::kTagNeverSeen, "tag_never_seen", true, false},
    {RunFlagKind::kWrongTagId, "wrong_tag_id", true, true},
    {RunFlagKind::kDuplicateTagId, "duplicate_tag_id", true, true},
    {RunFlagKind::kTagOutOfViewMidRun, "tag_out_of_view_mid_run", false, false},
    {RunFlagKind::kNoStartRest, "no_start_rest", true, false},
    {RunFlagKind::kNoEndRest, "no_end_rest", true, false},
    {RunFlagKind::kShortStartRest, "short_start_rest", false, false},
    {RunFlagKind::kShortEndRest, "short_end_rest", false, false},
    {RunFlagKind::kImageQuality, "image_quality", true, false},
    {RunFlagKind::kExactRefinementFailed, "exact_refinement_failed", false, false},
    {RunFlagKind::kNanFrames, "nan_frames", false, false},
    {RunFlagKind::kTrackerJump, "tracker_jump", false, false},
    {RunFlagKind::kTrackerNeverValid, "tracker_never_valid", false, false},
    {RunFlagKind::kClockOffset, "clock_offset", false, false},
    {RunFlagKind::kStartRestFromStillWheels, "start_rest_from_still_wheels", false, false},
    {RunFlagKind::kStartRestFromFirstPose, "start_rest_from_first_pose", false, false},
    {RunFlagKind::kEndRestFromStillWheels, "end_rest_from_still_wheels", false, false},
    {RunFlagKind::kEndRestFromLastPose, "end_rest_from_last_pose", false, false},
    {RunFlagKind::kDefaultFrameSigma, "default_frame_sigma", false, false},
};

void PrintTo(const KindCase& c, std::ostream* os) { *os << c.name; }

class RunFlagKindTest : public testing::TestWithParam<KindCase> {};

TEST_P(RunFlagKindTest, NameIsTheStableOne) {
  EXPECT_STREQ(Name(GetParam().kind), GetParam().name);
  EXPECT_EQ(RunFlag::Of(GetParam().kind).ToString(), GetParam().name);
}

TEST_P(RunFlagKindTest, FatalAsDocumented) {
  EXPECT_EQ(IsFatal(GetParam().kind), GetParam().fatal);
  EXPECT_EQ(RunFlag::Of(GetParam().kind).fatal(), GetParam().fatal);
  EXPECT_EQ(RunFlag::Of(GetParam().kind, "x").fatal(), GetParam().fatal);
  EXPECT_EQ(AnyFatal({RunFlag::Of(GetParam().kind)}), GetParam().fatal);
}

TEST_P(RunFlagKindTest, RoundTripsWithoutDetail) {
  const RunFlag flag = RunFlag::Of(GetParam().kind);
  const std::optional<RunFlag> parsed = ParseRunFlag(flag.ToString());
  ASSERT_TRUE(parsed.has_value()) << flag.ToString();
  EXPECT_EQ(*parsed, flag);
  EXPECT_TRUE(parsed->detail.empty());
}

TEST_P(RunFlagKindTest, RoundTripsWithDetail) {
  // A detail holding the separators themselves must survive too.
  for (const std::string detail : {"1.2s", "start_rest:overexposed", "cannot open: x.mp4", "7"}) {
    const RunFlag flag = RunFlag::Of(GetParam().kind, detail);
    const std::string text = flag.ToString();
    const std::string separator = GetParam().message_detail ? ": " : ":";
    EXPECT_EQ(text, std::string(GetParam().name) + separator + detail);
    const std::optional<RunFlag> parsed = ParseRunFlag(text);
    ASSERT_TRUE(parsed.has_value()) << text;
    EXPECT_EQ(parsed->kind, GetParam().kind) << text;
    EXPECT_EQ(parsed->detail, detail) << text;
  }
}

INSTANTIATE_TEST_SUITE_P(AllKinds, RunFlagKindTest, testing::ValuesIn(kCases),
                         [](const testing::TestParamInfo<KindCase>& info) {
                           return std::string(info.param.name);
                         });

TEST(RunFlag, EveryKindIsCoveredAndNamesAreDistinct) {
  // kDefaultFrameSigma is the last enumerator: the table above lists them all.
  EXPECT_EQ(static_cast<int>(RunFlagKind::kDefaultFrameSigma) + 1,
            static_cast<int>(std::size(kCases)));
  for (size_t i = 0; i < std::size(kCases); ++i) {
    EXPECT_EQ(static_cast<int>(kCases[i].kind), static_cast<int>(i));
    for (size_t j = i + 1; j < std::size(kCases); ++j)
      EXPECT_STRNE(Name(kCases[i].kind), Name(kCases[j].kind));
  }
}

TEST(RunFlag, TextsJsonConsumersReadAreExact) {
  EXPECT_EQ(RunFlag::Of(RunFlagKind::kNoEndRest).ToString(), "no_end_rest");
  EXPECT_EQ(RunFlag::Of(RunFlagKind::kTagOutOfViewMidRun, "1.2s").ToString(),
            "tag_out_of_view_mid_run:1.2s");
  EXPECT_EQ(RunFlag::Of(RunFlagKind::kImageQuality, "start_rest:overexposed").ToString(),
            "image_quality:start_rest:overexposed");
  EXPECT_EQ(RunFlag::Of(RunFlagKind::kVideoUnreadable, "moov atom not found").ToString(),
            "video_unreadable: moov atom not found");
  EXPECT_EQ(RunFlag::Of(RunFlagKind::kClockOffset, "+0.120s").ToString(), "clock_offset:+0.120s");
  std::ostringstream os;
  os << RunFlag::Of(RunFlagKind::kNanFrames, "3");
  EXPECT_EQ(os.str(), "nan_frames:3");
}

TEST(RunFlag, ParsesTheDocumentedExamples) {
  EXPECT_EQ(ParseRunFlag("tag_out_of_view_mid_run:1.2s"),
            RunFlag::Of(RunFlagKind::kTagOutOfViewMidRun, "1.2s"));
  EXPECT_EQ(ParseRunFlag("image_quality:start_rest:overexposed"),
            RunFlag::Of(RunFlagKind::kImageQuality, "start_rest:overexposed"));
  EXPECT_EQ(ParseRunFlag("video_unreadable: moov atom not found"),
            RunFlag::Of(RunFlagKind::kVideoUnreadable, "moov atom not found"));
  EXPECT_EQ(ParseRunFlag("no_end_rest"), RunFlag::Of(RunFlagKind::kNoEndRest));
}

TEST(RunFlag, TextNamingNoKindIsNullopt) {
  for (const std::string text :
       {"", "no_such_flag", "no_end", "no_end_rest_", "NO_END_REST", " no_end_rest", ":1.2s",
        "tag_out_of_view:1.2s"})
    EXPECT_EQ(ParseRunFlag(text), std::nullopt) << '"' << text << '"';
}

TEST(RunFlag, MessageKindWithoutItsSeparatorIsNullopt) {
  // "video_unreadable" puts ": " before its message; a bare ':' is not its form.
  EXPECT_EQ(ParseRunFlag("video_unreadable:oops"), std::nullopt);
}

TEST(RunFlag, AnyFatalAndToStrings) {
  EXPECT_FALSE(AnyFatal({}));
  const std::vector<RunFlag> benign = {RunFlag::Of(RunFlagKind::kShortStartRest),
                                       RunFlag::Of(RunFlagKind::kTagOutOfViewMidRun, "0.4s")};
  EXPECT_FALSE(AnyFatal(benign));
  std::vector<RunFlag> mixed = benign;
  mixed.push_back(RunFlag::Of(RunFlagKind::kNoEndRest));
  EXPECT_TRUE(AnyFatal(mixed));
  EXPECT_THAT(ToStrings(mixed), testing::ElementsAre("short_start_rest", "tag_out_of_view_mid_run:0.4s",
                                                     "no_end_rest"));
  EXPECT_TRUE(ToStrings(std::vector<RunFlag>{}).empty());
}

}  // namespace
}  // namespace odocal::calibration
