// `odocal watch` (issue 13 §4, the live view) end to end: a clip rendered by
// `odocal simulate` (a 250 mm cw square, 960x540, 10 fps), watched by the
// real binary in the background, its page opened by headless Chromium on a
// desktop-sized and a phone-sized window. The screenshots must show the tag's
// outline in the camera image, the square driven in the trajectory canvas
// and the warnings box; the phone's layout must not overflow sideways; the
// state the page reads must agree with the simulator's truth. And bad input
// (an option, a camera, a port in use) is exit 2 naming it. ~15 s in all.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

// Eigen (through test_util.h) before httplib.h: httplib includes <resolv.h>, whose
// `_res` macro breaks Eigen's headers included after it.
#include <Eigen/Core>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/videoio.hpp>

#include "odocal/test_util/test_util.h"

extern char** environ;

namespace odocal {
namespace {

using test_util::CommandResult;
using test_util::Odocal;
using test_util::RunCommand;
using ::testing::HasSubstr;

constexpr const char* kScenario = R"(seed: 4
robot:
  nominal: {left_wheel_diameter_mm: 70.0, right_wheel_diameter_mm: 70.0, track_mm: 300.0, ticks_per_rev: 2048}
  true:    {left_wheel_diameter_mm: 69.95, right_wheel_diameter_mm: 70.06, track_mm: 302.0}
  start_pose: {x_mm: -125, y_mm: 100, heading_deg: 0}
  speed_mm_s: 400
  turn_rate_deg_s: 180
  rest_s: 0.5
  noise: {wheel_mm_per_sqrt_m: 0.05}
runs:
  - {procedure: umbmark, direction: cw, side_mm: 250}
tag: {family: tag36h11, id: 5, size_mm: 80, height_mm: 150}
camera:
  width: 960
  height: 540
  fx: 1400
  fy: 1400
  cx: 480
  cy: 270
  distortion: [-0.12, 0.05, 0, 0, 0]
  pose: {x_mm: 0, y_mm: 0, height_mm: 2000, roll_deg: 0, pitch_deg: 3, yaw_deg: 0}
  fps: 10
  noise_sigma: 0.5
  blur_sigma_px: 0.8
  exposure_ms: 4
  crf: 18
  one_video: true
effects: []
)";

// `odocal watch ...` in the background: its stdout through a pipe, its pid
// for Ctrl-C. Killed on the way out if a test ends early.
class Background {
 public:
  Background(const std::vector<std::string>& args, const std::string& err_path) {
    int fds[2];
    if (pipe(fds) != 0) return;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], 1);
    posix_spawn_file_actions_addopen(&actions, 2, err_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    posix_spawn_file_actions_addclose(&actions, fds[0]);
    std::vector<char*> argv;
    for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    if (posix_spawn(&pid_, argv[0], &actions, nullptr, argv.data(), environ) != 0) pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
    close(fds[1]);
    out_ = fdopen(fds[0], "r");
  }
  ~Background() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
    if (out_) fclose(out_);
  }
  bool started() const { return pid_ > 0 && out_; }
  // The next line of its stdout ("" at the end).
  std::string ReadLine() {
    char buf[1024];
    return out_ && fgets(buf, sizeof(buf), out_) ? std::string(buf) : std::string();
  }
  // Sends `signal`, reads the rest of stdout and waits: the exit code (-1 if killed).
  int Stop(int signal, std::string* rest) {
    kill(pid_, signal);
    for (std::string line; !(line = ReadLine()).empty();) *rest += line;
    int status = 0;
    waitpid(pid_, &status, 0);
    pid_ = -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  }

 private:
  pid_t pid_ = -1;
  FILE* out_ = nullptr;
};

struct Box {
  int x = 0, y = 0, w = 0, h = 0;
  bool Contains(int px, int py) const { return px >= x && px < x + w && py >= y && py < y + h; }
};

// <body data-NAME="x,y,w,h"> as the page writes it (live_page.cc).
std::optional<Box> BodyBox(const std::string& dom, const std::string& name) {
  const std::regex re("data-" + name + R"re(="(-?\d+),(-?\d+),(\d+),(\d+)")re");
  std::smatch m;
  if (!std::regex_search(dom, m, re)) return std::nullopt;
  return Box{std::stoi(m[1]), std::stoi(m[2]), std::stoi(m[3]), std::stoi(m[4])};
}
std::optional<int> BodyInt(const std::string& dom, const std::string& name) {
  const std::regex re("data-" + name + R"re(="(\d+)")re");
  std::smatch m;
  if (!std::regex_search(dom, m, re)) return std::nullopt;
  return std::stoi(m[1]);
}

// The page's colours (live_page.cc, live_state.h), with room for JPEG and anti-aliasing.
bool IsOutline(const cv::Vec3b& bgr) { return bgr[2] > 170 && bgr[0] > 170 && bgr[1] < 110; }     // magenta
bool IsTrajectory(const cv::Vec3b& bgr) {  // #0066ff
  return bgr[0] > 200 && bgr[2] < 80 && bgr[1] > 60 && bgr[1] < 150;
}
bool IsWarning(const cv::Vec3b& bgr) { return bgr[2] > 170 && bgr[1] < 80 && bgr[0] < 80; }       // #c62828

struct Found {
  int count = 0, outside = 0;
  cv::Rect bbox;
};
// Pixels of a colour: how many inside `box` (all of the image without one),
// how many outside, and the bounding box of those inside.
template <typename Pred>
Found FindColour(const cv::Mat& image, Pred pred, const std::optional<Box>& box = std::nullopt) {
  Found f;
  int x0 = image.cols, y0 = image.rows, x1 = -1, y1 = -1;
  for (int y = 0; y < image.rows; ++y)
    for (int x = 0; x < image.cols; ++x) {
      if (!pred(image.at<cv::Vec3b>(y, x))) continue;
      if (box && !box->Contains(x, y)) {
        ++f.outside;
        continue;
      }
      ++f.count;
      x0 = std::min(x0, x), y0 = std::min(y0, y), x1 = std::max(x1, x), y1 = std::max(y1, y);
    }
  if (f.count > 0) f.bbox = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
  return f;
}

class WatchCli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = test_util::MakeTempDir("odocal_watch_");
    video_ = dir_ + "/sim/recording.mp4";
    calibration_ = dir_ + "/sim/camera.yaml";
  }
  void Render() {
    std::ofstream(dir_ + "/scenario.yaml") << kScenario;
    const CommandResult sim =
        RunCommand(Odocal("simulate --scenario " + dir_ + "/scenario.yaml --out " + dir_ + "/sim"));
    ASSERT_EQ(sim.exit_code, 0) << sim.err;
  }
  CommandResult Chromium(const std::string& args, const std::string& url) {
    return RunCommand("chromium --headless=new --no-sandbox --disable-gpu --disable-dev-shm-usage --hide-scrollbars --user-data-dir=" + dir_ +
                      "/chromium --virtual-time-budget=4000 " + args + " " + url);
  }
  std::string dir_, video_, calibration_;
};

TEST_F(WatchCli, TheLivePageInHeadlessChromiumOnADesktopAndAPhone) {
  ASSERT_EQ(RunCommand("command -v chromium").exit_code, 0)
      << "chromium is missing: bash scripts/install-deps.sh installs it";
  Render();
  ASSERT_FALSE(HasFatalFailure());
  Background watch({test_util::OdocalBinary(), "watch", video_, "--calibration", calibration_, "--tag",
                    "tag36h11:5:80:150", "--port", "0", "--hold-s", "120"},
                   dir_ + "/watch.err");
  ASSERT_TRUE(watch.started());
  const std::string first = watch.ReadLine();
  std::smatch m;
  ASSERT_TRUE(std::regex_search(first, m, std::regex(R"(^live view: (http://127\.0\.0\.1:(\d+)/)\n$)")))
      << first << test_util::Slurp(dir_ + "/watch.err");
  const std::string url = m[1];
  const int port = std::stoi(m[2]);
  const std::string summary = watch.ReadLine();  // the video is read as fast as it decodes
  ASSERT_TRUE(std::regex_search(summary, m, std::regex(R"(^watched (\d+) frames in .* tag found in (\d+))")))
      << summary;
  const int frames = std::stoi(m[1]);
  EXPECT_GT(frames, 80);
  EXPECT_EQ(std::stoi(m[2]), frames);

  {
    SCOPED_TRACE("the state the page reads, against the simulator's truth");
    httplib::Client client("127.0.0.1", port);
    const auto res = client.Get("/state.json");
    ASSERT_TRUE(res);
    const nlohmann::json s = nlohmann::json::parse(res->body);
    EXPECT_EQ(s["frame"]["seq"], frames);
    // The truth of the last frame: robot_x_mm, robot_y_mm, robot_heading_deg.
    std::ifstream csv(dir_ + "/sim/recording.frames.csv");
    std::string line, last;
    while (std::getline(csv, line))
      if (!line.empty()) last = line;
    std::vector<double> v;
    std::stringstream fields(last);
    for (std::string f; std::getline(fields, f, ',');) v.push_back(std::stod(f));
    ASSERT_GE(v.size(), 7u);
    // Absolute position is as good as the fitted tilt: +-0.15 deg of roll
    // (its sigma from 30 views) is +-5 mm at the tag's 1.85 m.
    EXPECT_NEAR(s["pose"]["x_mm"].get<double>(), v[4], 12.0);
    EXPECT_NEAR(s["pose"]["y_mm"].get<double>(), v[5], 12.0);
    EXPECT_NEAR(s["pose"]["heading_deg"].get<double>(), v[6], 0.5);
    EXPECT_GT(s["trajectory_mm"].size(), 50u);
    ASSERT_GE(s["estimates"].size(), 1u);
    EXPECT_EQ(s["estimates"][0]["name"], "camera height");
    EXPECT_NEAR(s["estimates"][0]["value"].get<double>(), 2000.0, 20.0);
    ASSERT_EQ(s["warnings"].size(), 1u) << s["warnings"].dump();
    EXPECT_EQ(s["warnings"][0]["key"], "source_ended");
  }

  {
    SCOPED_TRACE("desktop, 1280x900");
    const CommandResult dom = Chromium("--window-size=1280,900 --dump-dom", url);
    ASSERT_EQ(dom.exit_code, 0) << dom.err;
    const auto cam = BodyBox(dom.out, "cam"), traj = BodyBox(dom.out, "traj"), warn = BodyBox(dom.out, "warnings");
    ASSERT_TRUE(cam && traj && warn) << dom.out.substr(0, 2000);
    EXPECT_EQ(BodyInt(dom.out, "cam-loaded"), 1);
    EXPECT_EQ(BodyInt(dom.out, "frame-seq"), frames);
    EXPECT_LT(cam->x + cam->w, traj->x) << "two columns: the camera left of the trajectory";
    const std::string png = dir_ + "/desktop.png";
    const CommandResult shot = Chromium("--window-size=1280,900 --screenshot=" + png, url);
    ASSERT_EQ(shot.exit_code, 0) << shot.err;
    const cv::Mat image = cv::imread(png, cv::IMREAD_COLOR);
    ASSERT_EQ(image.cols, 1280);
    ASSERT_EQ(image.rows, 900);
    const Found outline = FindColour(image, IsOutline, cam);
    EXPECT_GT(outline.count, 60) << "the tag's outline in the camera image";
    EXPECT_LT(outline.outside, 5);
    // The outline is the tag's: about 60 px across at 960 px, shown 726 px wide.
    EXPECT_NEAR(outline.bbox.width, 60.0 * cam->w / 960, 12.0);
    const Found path = FindColour(image, IsTrajectory, traj);
    EXPECT_GT(path.count, 300) << "the trajectory over the grid";
    EXPECT_LT(path.outside, 5);
    // The square driven, drawn square (one scale for x and y).
    EXPECT_NEAR(static_cast<double>(path.bbox.width) / path.bbox.height, 1.0, 0.25) << path.bbox;
    const Found red = FindColour(image, IsWarning, warn);
    EXPECT_GT(red.count, warn->w * warn->h / 2) << "the warnings box is red";
  }

  {
    SCOPED_TRACE("phone, 412x915");
    const std::string png = dir_ + "/phone.png";
    const CommandResult shot = Chromium("--window-size=412,915 --screenshot=" + png, url);
    ASSERT_EQ(shot.exit_code, 0) << shot.err;
    const cv::Mat image = cv::imread(png, cv::IMREAD_COLOR);
    ASSERT_EQ(image.cols, 412);
    const Found outline = FindColour(image, IsOutline);
    const Found path = FindColour(image, IsTrajectory);
    const Found red = FindColour(image, IsWarning);
    EXPECT_GT(outline.count, 30);
    EXPECT_GT(path.count, 150);
    EXPECT_GT(red.count, 3000);
    // One column: warnings, then the camera, then the trajectory, all on the first screen.
    EXPECT_LT(red.bbox.y + red.bbox.height, outline.bbox.y);
    EXPECT_LT(outline.bbox.y + outline.bbox.height, path.bbox.y);
    EXPECT_LT(path.bbox.y + path.bbox.height, image.rows);
    // Nothing wider than the screen: the trajectory's panel (white) has the
    // same margin left and right, as the page's padding gives it.
    const int row = path.bbox.y + path.bbox.height / 2;
    int left = -1, right = -1;
    for (int x = 0; x < image.cols; ++x) {
      const cv::Vec3b p = image.at<cv::Vec3b>(row, x);
      if (p[0] == 255 && p[1] == 255 && p[2] == 255) {
        if (left < 0) left = x;
        right = x;
      }
    }
    ASSERT_GE(left, 0);
    EXPECT_GT(left, 0);
    EXPECT_NEAR(left, image.cols - 1 - right, 2) << "panel from x " << left << " to " << right;
    // And as the page measures itself at Chromium's narrowest window for
    // --dump-dom (500 px: it does not go below that).
    const CommandResult dom = Chromium("--window-size=412,915 --dump-dom", url);
    ASSERT_EQ(dom.exit_code, 0) << dom.err;
    const auto width = BodyInt(dom.out, "viewport-width"), scroll = BodyInt(dom.out, "scroll-width");
    const auto cam = BodyBox(dom.out, "cam"), traj = BodyBox(dom.out, "traj");
    ASSERT_TRUE(width && scroll && cam && traj) << dom.out.substr(0, 2000);
    EXPECT_LT(*width, 760) << "the one-column layout";
    EXPECT_LE(*scroll, *width) << "the page scrolls sideways";
    EXPECT_EQ(cam->x, traj->x) << "one column";
    EXPECT_LT(cam->y, traj->y);
    EXPECT_LE(cam->x + cam->w, *width);
    EXPECT_GT(cam->w, *width * 8 / 10) << "the image uses the screen's width";
  }

  // Ctrl-C ends the hold (120 s) at once, and cleanly.
  std::string rest;
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_EQ(watch.Stop(SIGINT, &rest), 0) << rest << test_util::Slurp(dir_ + "/watch.err");
  EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(), 5.0);
  std::filesystem::remove_all(dir_ + "/chromium");  // its profile: megabytes; the screenshots stay
}

// A port held by another program.
class HeldPort {
 public:
  HeldPort() {
    sock_ = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    if (bind(sock_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0 || listen(sock_, 1) != 0) return;
    socklen_t len = sizeof(addr);
    getsockname(sock_, reinterpret_cast<sockaddr*>(&addr), &len);
    port_ = ntohs(addr.sin_port);
  }
  ~HeldPort() { close(sock_); }
  int port() const { return port_; }

 private:
  int sock_ = -1;
  int port_ = 0;
};

TEST_F(WatchCli, BadInputIsExit2NamingIt) {
  // A small clip and calibrations for it and for another camera.
  const std::string video = dir_ + "/clip.avi";
  {
    cv::VideoWriter writer(video, cv::VideoWriter::fourcc('M', 'J', 'P', 'G'), 10.0, cv::Size(160, 120), false);
    ASSERT_TRUE(writer.isOpened());
    for (int i = 0; i < 3; ++i) writer.write(cv::Mat(120, 160, CV_8UC1, cv::Scalar(60 * i)));
  }
  auto camera_file = [&](const std::string& name, int width, int height) {
    std::ofstream(dir_ + "/" + name) << "%YAML:1.0\n---\nimage_width: " << width << "\nimage_height: " << height
                                     << "\ncamera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n"
                                        "   data: [ 200., 0., 80., 0., 200., 60., 0., 0., 1. ]\n"
                                        "distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n"
                                        "   dt: d\n   data: [ 0., 0., 0., 0., 0. ]\n";
    return dir_ + "/" + name;
  };
  const std::string calibration = camera_file("camera.yaml", 160, 120);
  const std::string other = camera_file("other.yaml", 320, 240);
  const std::string common = " --calibration " + calibration + " --tag tag36h11:5:80:150";
  // It works with these (no tag in view: the clip is blank)...
  const CommandResult ok = RunCommand(Odocal("watch " + video + common + " --port 0"));
  ASSERT_EQ(ok.exit_code, 0) << ok.out << ok.err;
  EXPECT_THAT(ok.out, HasSubstr("watched 3 frames"));
  // ... and each of these is exit 2 with a line naming what is wrong.
  HeldPort held;
  ASSERT_GT(held.port(), 0);
  struct Case {
    std::string args, says;
  };
  const std::vector<Case> cases = {
      {video + " --calibration " + calibration + " --tag tag36h11:five:80", "--tag tag36h11:five:80"},
      {video + " --calibration " + calibration + " --tag tag99h9:5:80", "unknown family 'tag99h9'"},
      {dir_ + "/missing.mp4" + common, "CAMERA " + dir_ + "/missing.mp4: no such file"},
      {"/dev/video63" + common, "CAMERA /dev/video63: cannot be opened"},
      {video + common + " --port 70000", "--port 70000"},
      {video + common + " --bind localhost", "--bind localhost"},
      {video + " --calibration " + dir_ + "/none.yaml --tag tag36h11:5:80", "--calibration"},
      {video + " --calibration " + other + " --tag tag36h11:5:80 --port 0", "delivers 160x120 frames"},
      {video + common + " --mount-guess 1,2,3", "--mount-guess 1,2,3"},
      {video + common + " --port " + std::to_string(held.port()),
       "127.0.0.1:" + std::to_string(held.port()) + " is in use"},
  };
  for (const Case& c : cases) {
    const CommandResult r = RunCommand(Odocal("watch " + c.args));
    EXPECT_EQ(r.exit_code, 2) << c.args << "\n" << r.out << r.err;
    EXPECT_THAT(r.err, HasSubstr("odocal watch: ")) << c.args;
    EXPECT_THAT(r.err, HasSubstr(c.says)) << c.args;
  }
}

}  // namespace
}  // namespace odocal
