// LiveServer (rig/live): every endpoint answered over loopback by a real HTTP
// client (cpp-httplib's), the port chosen or taken, and a clean stop.
#include "odocal/live/live_server.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <string>
#include <thread>

#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <httplib.h>
#include <opencv2/imgcodecs.hpp>

namespace odocal::live {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using Clock = std::chrono::steady_clock;

LiveServerOptions AnyPort() {
  LiveServerOptions o;
  o.port = 0;
  return o;
}

std::unique_ptr<LiveServer> StartOrDie(const LiveState& state, const LiveServerOptions& o = AnyPort()) {
  auto server = LiveServer::Start(state, o);
  EXPECT_TRUE(server.ok()) << server.message;
  return server.ok() ? std::move(*server) : nullptr;
}

cv::Mat Frame(int width, int height, int shade) { return cv::Mat(height, width, CV_8UC1, cv::Scalar(shade)); }

TEST(LiveServer, PortZeroGivesARealPortAndTheUrlNamesIt) {
  LiveState state;
  auto server = StartOrDie(state);
  ASSERT_TRUE(server);
  EXPECT_GT(server->port(), 0);
  EXPECT_NE(server->port(), 8080);
  EXPECT_EQ(server->url(), "http://127.0.0.1:" + std::to_string(server->port()) + "/");
}

TEST(LiveServer, ThePageIsSelfContainedAndLaidOutForAPhone) {
  LiveState state;
  auto server = StartOrDie(state);
  ASSERT_TRUE(server);
  httplib::Client client("127.0.0.1", server->port());
  const auto res = client.Get("/");
  ASSERT_TRUE(res) << httplib::to_string(res.error());
  EXPECT_EQ(res->status, 200);
  EXPECT_THAT(res->get_header_value("Content-Type"), HasSubstr("text/html"));
  EXPECT_EQ(res->body, LivePageHtml());
  EXPECT_THAT(res->body, HasSubstr(R"(<meta name="viewport" content="width=device-width)"));
  EXPECT_THAT(res->body, HasSubstr("state.json"));
  EXPECT_THAT(res->body, HasSubstr("frame.jpg"));
  // Nothing fetched from elsewhere (the station may be offline).
  EXPECT_THAT(res->body, Not(HasSubstr("http://")));
  EXPECT_THAT(res->body, Not(HasSubstr("https://")));
  EXPECT_THAT(res->body, Not(HasSubstr("//cdn")));
  EXPECT_EQ(client.Get("/nothing-here")->status, 404);
}

TEST(LiveServer, StateJsonIsTheStates) {
  LiveState state;
  state.SetSource("caf\xe9.mp4");  // Latin-1, not UTF-8: replaced, not a failed request
  state.SetProgress(2, 6, "UMBMark ccw", "round 1");
  state.SetEstimate("Ed", 1.001, 0.0002, "");
  auto server = StartOrDie(state);
  ASSERT_TRUE(server);
  httplib::Client client("127.0.0.1", server->port());
  const auto res = client.Get("/state.json");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_THAT(res->get_header_value("Content-Type"), HasSubstr("application/json"));
  EXPECT_EQ(res->get_header_value("Cache-Control"), "no-store");
  const nlohmann::json j = nlohmann::json::parse(res->body);
  EXPECT_EQ(j["source"], "caf\xef\xbf\xbd.mp4");  // U+FFFD
  EXPECT_EQ(j["frame"], state.StateJson()["frame"]);
  EXPECT_EQ(j["progress"]["run_index"], 2);
  EXPECT_EQ(j["estimates"][0]["name"], "Ed");
}

TEST(LiveServer, FrameJpegDecodesToTheFramesSize) {
  LiveState state;
  auto server = StartOrDie(state);
  ASSERT_TRUE(server);
  httplib::Client client("127.0.0.1", server->port());
  const auto none = client.Get("/frame.jpg");
  ASSERT_TRUE(none);
  EXPECT_EQ(none->status, 503);
  state.OnFrame(Frame(640, 360, 90), 0.0, std::nullopt, std::nullopt);
  const auto res = client.Get("/frame.jpg");
  ASSERT_TRUE(res);
  EXPECT_EQ(res->status, 200);
  EXPECT_EQ(res->get_header_value("Content-Type"), "image/jpeg");
  EXPECT_EQ(res->get_header_value("X-Frame-Seq"), "1");
  const cv::Mat image = cv::imdecode(std::vector<unsigned char>(res->body.begin(), res->body.end()), cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty());
  EXPECT_EQ(image.cols, 640);
  EXPECT_EQ(image.rows, 360);
  EXPECT_NEAR(image.at<cv::Vec3b>(100, 100)[1], 90, 3);
}

// Splits a multipart/x-mixed-replace body into its JPEG parts.
std::vector<std::string> JpegParts(const std::string& body) {
  std::vector<std::string> parts;
  size_t at = 0;
  for (;;) {
    const size_t header = body.find("Content-Length: ", at);
    if (header == std::string::npos) break;
    const size_t end_of_headers = body.find("\r\n\r\n", header);
    if (end_of_headers == std::string::npos) break;
    const size_t length = std::stoul(body.substr(header + 16, end_of_headers - header - 16));
    if (end_of_headers + 4 + length > body.size()) break;
    parts.push_back(body.substr(end_of_headers + 4, length));
    at = end_of_headers + 4 + length;
  }
  return parts;
}

TEST(LiveServer, StreamDeliversSuccessiveJpegParts) {
  LiveState state;
  LiveServerOptions o = AnyPort();
  o.stream_max_fps = 50.0;
  auto server = StartOrDie(state, o);
  ASSERT_TRUE(server);
  std::atomic<bool> done{false};
  std::thread producer([&] {
    for (int i = 0; !done && i < 1000; ++i) {
      // A shade repeats only after 56 frames (1.1 s): two parts, however
      // far apart a busy machine delivers them, show different shades.
      state.OnFrame(Frame(320, 240, 16 + (i % 56) * 4), i * 0.02, std::nullopt, std::nullopt);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  httplib::Client client("127.0.0.1", server->port());
  client.set_read_timeout(5, 0);
  std::string content_type, body;
  const auto res = client.Get(
      "/stream.mjpg",
      [&](const httplib::Response& r) {
        content_type = r.get_header_value("Content-Type");
        return true;
      },
      [&](const char* data, size_t length) {
        body.append(data, length);
        return JpegParts(body).size() < 3;  // enough: hang up
      });
  done = true;
  producer.join();
  EXPECT_THAT(content_type, HasSubstr("multipart/x-mixed-replace; boundary=odocal-frame"));
  EXPECT_THAT(body, HasSubstr("--odocal-frame\r\nContent-Type: image/jpeg\r\n"));
  const std::vector<std::string> parts = JpegParts(body);
  ASSERT_GE(parts.size(), 2u);
  std::vector<int> shades;
  for (const std::string& p : parts) {
    const cv::Mat image = cv::imdecode(std::vector<unsigned char>(p.begin(), p.end()), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(image.empty());
    EXPECT_EQ(image.cols, 320);
    EXPECT_EQ(image.rows, 240);
    shades.push_back(image.at<unsigned char>(10, 10));
  }
  EXPECT_NE(shades[0], shades[1]) << "two parts, two different frames";
}

TEST(LiveServer, StreamsBeyondTheLimitAreRefused) {
  LiveState state;
  state.OnFrame(Frame(64, 48, 10), 0.0, std::nullopt, std::nullopt);
  LiveServerOptions o = AnyPort();
  o.max_streams = 1;
  auto server = StartOrDie(state, o);
  ASSERT_TRUE(server);
  std::atomic<bool> first_open{false}, release{false};
  std::thread first([&] {
    httplib::Client client("127.0.0.1", server->port());
    client.Get("/stream.mjpg", [&](const char*, size_t) {
      first_open = true;
      return !release.load();
    });
  });
  const Clock::time_point give_up = Clock::now() + std::chrono::seconds(5);
  while (!first_open && Clock::now() < give_up) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(first_open);
  httplib::Client second("127.0.0.1", server->port());
  const auto refused = second.Get("/stream.mjpg");
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->status, 503);
  release = true;
  state.OnFrame(Frame(64, 48, 20), 0.1, std::nullopt, std::nullopt);  // the first one's receiver says stop
  first.join();
}

TEST(LiveServer, APortInUseFailsSayingSo) {
  LiveState state;
  auto first = StartOrDie(state);
  ASSERT_TRUE(first);
  LiveServerOptions o;
  o.port = first->port();
  const auto second = LiveServer::Start(state, o);
  ASSERT_FALSE(second.ok()) << "a second server shares port " << o.port;
  EXPECT_EQ(second.status, StatusCode::kOpenFailed);
  EXPECT_THAT(second.message, HasSubstr("127.0.0.1:" + std::to_string(o.port) + " is in use"));

  // And a port held by a program that is not odocal.
  const int sock = socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(sock, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  addr.sin_port = 0;
  ASSERT_EQ(bind(sock, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)), 0);
  ASSERT_EQ(listen(sock, 1), 0);
  socklen_t len = sizeof(addr);
  ASSERT_EQ(getsockname(sock, reinterpret_cast<sockaddr*>(&addr), &len), 0);
  o.port = ntohs(addr.sin_port);
  const auto third = LiveServer::Start(state, o);
  close(sock);
  ASSERT_FALSE(third.ok());
  EXPECT_THAT(third.message, HasSubstr("is in use"));
}

TEST(LiveServer, BadOptionsAreRefusedNamingThem) {
  LiveState state;
  LiveServerOptions o;
  o.bind_address = "localhost";
  auto r = LiveServer::Start(state, o);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.status, StatusCode::kInvalidArgument);
  EXPECT_THAT(r.message, HasSubstr("'localhost' is not an IPv4 or IPv6 address"));
  o = LiveServerOptions{};
  o.port = 70000;
  r = LiveServer::Start(state, o);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.message, HasSubstr("port 70000"));
  o = LiveServerOptions{};
  o.bind_address = "192.0.2.1";  // TEST-NET-1: no machine's own address
  o.port = 0;
  r = LiveServer::Start(state, o);
  ASSERT_FALSE(r.ok());
  EXPECT_THAT(r.message, HasSubstr("not an address of this machine"));
}

TEST(LiveServer, StopsPromptlyWithClientsConnected) {
  LiveState state;
  state.OnFrame(Frame(64, 48, 10), 0.0, std::nullopt, std::nullopt);
  auto server = StartOrDie(state);
  ASSERT_TRUE(server);
  // An idle keep-alive connection and an open stream.
  httplib::Client idle("127.0.0.1", server->port());
  idle.set_keep_alive(true);
  ASSERT_TRUE(idle.Get("/state.json"));
  std::atomic<bool> streaming{false};
  std::thread viewer([&] {
    httplib::Client client("127.0.0.1", server->port());
    client.Get("/stream.mjpg", [&](const char*, size_t) {
      streaming = true;
      return true;
    });
  });
  const Clock::time_point give_up = Clock::now() + std::chrono::seconds(5);
  while (!streaming && Clock::now() < give_up) std::this_thread::sleep_for(std::chrono::milliseconds(5));
  ASSERT_TRUE(streaming);
  const Clock::time_point t0 = Clock::now();
  server->Stop();
  const double took = std::chrono::duration<double>(Clock::now() - t0).count();
  viewer.join();
  EXPECT_LT(took, 3.0);
  server->Stop();  // again: nothing
  httplib::Client late("127.0.0.1", server->port());
  late.set_connection_timeout(1, 0);
  EXPECT_FALSE(late.Get("/state.json")) << "still answering after Stop()";
}

}  // namespace
}  // namespace odocal::live
