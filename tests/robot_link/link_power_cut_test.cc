// Power cuts during a commit, at every byte: of the storage record being
// written, and of the commit frame arriving. After the "reboot" the robot
// holds the old set or the new one, never a mix.
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "link_test_util.h"
#include "odocal/robot_link/client.h"
#include "odocal/robot_link/firmware_host.h"

namespace odocal::robot_link {
namespace {

const ParamSet kA{70.0, 70.25, 300.0, 2048};
const ParamSet kB{71.5, 69.75, 310.125, 4096};
const ParamSet kC{72.0625, 72.5, 288.0, 1000};

ParamSet Reboot(MemoryStorage& storage) {
  FakeMotionBackend backend;
  LoopbackTransport link(RobotOptions{}, backend, &storage);
  return link.robot().active();
}

// Writes `history` fully, then pushes `next` with the power failing after
// `budget` bytes of the storage write.
void CutDuringPersist(const std::vector<ParamSet>& history, const ParamSet& next, uint64_t budget,
                      int* old_count, int* new_count) {
  MemoryStorage storage;
  FakeMotionBackend backend;
  LoopbackTransport link(RobotOptions{}, backend, &storage);
  ClientOptions co;
  co.first_seq = 1;
  Client client(link, co);
  for (const ParamSet& s : history) ASSERT_TRUE(client.PushParams(s).ok());
  const ParamSet old = history.back();
  storage.SetPowerBudget(budget);
  Result<PushReport> r = client.PushParams(next);
  storage.SetPowerBudget(std::nullopt);
  const bool complete = budget >= OLF_STORAGE_RECORD_SIZE;
  EXPECT_EQ(r.ok(), complete) << "budget " << budget << ": " << r;
  // In RAM: the new set only if the record was fully written.
  EXPECT_TRUE(link.robot().active().SameBits(complete ? next : old)) << "budget " << budget;
  const ParamSet booted = Reboot(storage);
  const bool is_old = booted.SameBits(old), is_new = booted.SameBits(next);
  EXPECT_TRUE(is_old || is_new) << "budget " << budget << " boots a mix: " << booted;
  EXPECT_EQ(is_new, complete) << "budget " << budget;
  *old_count += is_old;
  *new_count += is_new;
}

TEST(LinkPowerCut, EveryByteOfTheStorageRecordInBothSlots) {
  int offsets = 0, old_count = 0, new_count = 0;
  // One push before: the new record goes to slot B. Two: back to slot A,
  // overwriting the oldest record while the newest stays intact.
  for (const auto& history : {std::vector<ParamSet>{kA}, std::vector<ParamSet>{kA, kB}}) {
    for (uint64_t budget = 0; budget <= OLF_STORAGE_RECORD_SIZE; ++budget) {
      CutDuringPersist(history, kC, budget, &old_count, &new_count);
      ++offsets;
    }
  }
  std::printf("[figures] storage power cuts: %d offsets (record %u bytes, 2 slots): %d booted old "
              "set, %d booted new set, %d mixed\n",
              offsets, OLF_STORAGE_RECORD_SIZE, old_count, new_count,
              offsets - old_count - new_count);
  EXPECT_EQ(offsets, 2 * (OLF_STORAGE_RECORD_SIZE + 1));
  EXPECT_EQ(new_count, 2);  // only the complete writes
}

TEST(LinkPowerCut, EveryByteOfTheCommitFrame) {
  // Stage kB completely, then deliver the commit frame only up to byte k and
  // cut the power: a robot that saw the frame's last byte has committed.
  const Bytes commit = EncodeFrame(
      testing::Request(OLF_MSG_COMMIT, 900, ByteWriter().U32(kB.Checksum()).Take()));
  int old_count = 0, new_count = 0;
  for (size_t k = 0; k <= commit.size(); ++k) {
    MemoryStorage storage;
    {
      FakeMotionBackend backend;
      LoopbackTransport link(RobotOptions{}, backend, &storage);
      ClientOptions co;
      co.first_seq = 1;
      Client client(link, co);
      ASSERT_TRUE(client.PushParams(kA).ok());
      ASSERT_TRUE(testing::RawExchange(link, testing::Request(OLF_MSG_STAGE_BEGIN, 800)));
      uint16_t seq = 801;
      for (size_t i = 0; i < ParamTable().size(); ++i) {
        ByteWriter w;
        w.Str8(std::string(ParamTable()[i].name)).U8(static_cast<uint8_t>(ParamTable()[i].type));
        if (i < 3) {
          w.F64(std::get<double>(kB.Get(i)));
        } else {
          w.U32(kB.ticks_per_rev);
        }
        ASSERT_TRUE(testing::RawExchange(link, testing::Request(OLF_MSG_STAGE_PUT, seq++, w.Take())));
      }
      link.Write(std::span(commit.data(), k));
    }  // power off
    const ParamSet booted = Reboot(storage);
    const bool is_old = booted.SameBits(kA), is_new = booted.SameBits(kB);
    EXPECT_TRUE(is_old || is_new) << "cut at byte " << k;
    // The frame counts once its closing delimiter (the last byte) is in.
    EXPECT_EQ(is_new, k == commit.size()) << "cut at byte " << k;
    old_count += is_old;
    new_count += is_new;
  }
  std::printf("[figures] commit-frame power cuts: %zu offsets (frame %zu bytes): %d booted old set, "
              "%d booted new set\n",
              commit.size() + 1, commit.size(), old_count, new_count);
}

TEST(LinkPowerCut, FileStorageSurvivesRestartAndIgnoresAStrayTempFile) {
  const std::string dir = ::testing::TempDir() + "/odocal_power_cut_" +
                          std::to_string(::testing::UnitTest::GetInstance()->random_seed());
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/params.bin";
  std::filesystem::remove(path);
  {
    Result<std::unique_ptr<FileStorage>> fs = FileStorage::Open(path);
    ASSERT_TRUE(fs.ok()) << fs;
    FakeMotionBackend backend;
    LoopbackTransport link(RobotOptions{}, backend, fs.value->get());
    Client client(link);
    ASSERT_TRUE(client.PushParams(kB).ok());
  }
  // A crash between writing the temp file and renaming it leaves this behind.
  {
    std::ofstream stray(path + ".tmp", std::ios::binary);
    stray << "half an image";
  }
  Result<std::unique_ptr<FileStorage>> fs = FileStorage::Open(path);
  ASSERT_TRUE(fs.ok()) << fs;
  FakeMotionBackend backend;
  LoopbackTransport link(RobotOptions{}, backend, fs.value->get());
  EXPECT_TRUE(link.robot().active().SameBits(kB));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace odocal::robot_link
