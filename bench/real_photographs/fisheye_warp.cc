// Real photographs through a fisheye: the aprilgrid data set's frames
// resampled into the image an equidistant (Kannala-Brandt) camera would take
// from the same place, with the peer's corners carried along.
//
//   real_fisheye_warp DATA_DIR OUT_DIR [--focal PX] [--size PX] [--k1 K] [--vignette V]
//                     [--turn-deg X,Y]
//
// --turn-deg turns the fisheye camera about the source's x and y axes (a
// Rodrigues vector in degrees): the board then lands towards the image's rim.
//
// Every figure odocal has on a fisheye is from rendered frames; the real
// frames have a rectilinear lens. Their light is real (blur, noise, JPEG,
// the printed board), their geometry is not a fisheye's. This tool keeps the
// first and replaces the second (tests/vision/fisheye_resample.h): the source
// camera is calibrated (cv::calibrateCamera, radtan) from the peer's corners,
// and each pixel of the fisheye image looks along its ray to where the source
// camera saw it.
//
// OUT_DIR gets the data set's layout (cam0/data/*.png, cam0/data.csv,
// grid0/cam0/data/<frame>.csv with the peer's corners mapped through the same
// two cameras, corners that leave the image dropped), the target file with
// `dist_model: equi4`, and truth.yaml: the fisheye camera (ROS camera_info).
// docs/vision.md ("Real photographs through a fisheye") runs calibrate-camera,
// detect and real_photographs_bench on it.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "fisheye_resample.h"

namespace fs = std::filesystem;

namespace {

struct PeerCorner {
  std::string line_head;  // ts,rows,cols,size,spacing
  double x = 0, y = 0;
  std::string line_tail;  // p_x,p_y,p_z,tag_id,corner_idx
  cv::Point3f board;
};

std::vector<std::string> Split(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream ss(s);
  for (std::string f; std::getline(ss, f, ',');) out.push_back(f);
  return out;
}

std::vector<PeerCorner> ReadPeer(const fs::path& csv) {
  std::vector<PeerCorner> out;
  std::ifstream in(csv);
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    const auto f = Split(line);
    if (f.size() != 12) continue;
    PeerCorner c;
    c.line_head = f[0] + "," + f[1] + "," + f[2] + "," + f[3] + "," + f[4];
    c.x = std::stod(f[5]);
    c.y = std::stod(f[6]);
    c.line_tail = f[7] + "," + f[8] + "," + f[9] + "," + f[10] + "," + f[11];
    c.board = cv::Point3f(std::stof(f[7]), std::stof(f[8]), std::stof(f[9]));
    out.push_back(c);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr,
                 "usage: %s DATA_DIR OUT_DIR [--focal PX] [--size PX] [--k1 K] [--vignette V] [--turn-deg X,Y]\n",
                 argv[0]);
    return 2;
  }
  const fs::path dir = argv[1], out = argv[2];
  double focal = 300, k1 = 0, vignette = 0;
  cv::Vec3d turn(0, 0, 0);
  int size = 416;
  for (int i = 3; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--focal")
      focal = std::stod(argv[i + 1]);
    else if (a == "--size")
      size = std::stoi(argv[i + 1]);
    else if (a == "--k1")
      k1 = std::stod(argv[i + 1]);
    else if (a == "--vignette")
      vignette = std::stod(argv[i + 1]);
    else if (a == "--turn-deg" && std::sscanf(argv[i + 1], "%lf,%lf", &turn[0], &turn[1]) == 2)
      turn *= M_PI / 180.0;
    else {
      std::fprintf(stderr, "unknown option %s\n", a.c_str());
      return 2;
    }
  }
  // Frames and the peer's corners.
  std::map<std::string, fs::path> frames, peers;
  for (const auto& e : fs::directory_iterator(dir / "cam0" / "data")) frames[e.path().stem().string()] = e.path();
  for (const auto& e : fs::directory_iterator(dir / "grid0" / "cam0" / "data"))
    peers[e.path().stem().string()] = e.path();
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> image;
  cv::Size source_size;
  for (const auto& [stem, path] : frames) {
    if (!peers.count(stem)) continue;
    const auto corners = ReadPeer(peers[stem]);
    if (corners.size() < 16) continue;
    std::vector<cv::Point3f> o;
    std::vector<cv::Point2f> p;
    for (const auto& c : corners) {
      o.push_back(c.board);
      p.emplace_back(static_cast<float>(c.x), static_cast<float>(c.y));
    }
    object.push_back(o);
    image.push_back(p);
    if (source_size.area() == 0) source_size = cv::imread(path.string(), cv::IMREAD_GRAYSCALE).size();
  }
  cv::Mat K, D;
  std::vector<cv::Mat> rvecs, tvecs;
  const double rms = cv::calibrateCamera(object, image, source_size, K, D, rvecs, tvecs);
  D = D.rowRange(0, 1).colRange(0, 4).clone();  // radtan4 (k1, k2, p1, p2), as the data set's camera file
  std::printf(
      "source camera (radtan from %zu frames of the peer's corners): RMS %.4f px, fx %.3f fy %.3f cx %.3f cy %.3f, D "
      "%s\n",
      object.size(), rms, K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2),
      [&] {
        std::ostringstream s;
        s << D;
        return s.str();
      }()
          .c_str());

  const odocal::testing::FisheyeResample fisheye(K, D, source_size, focal, size, k1, vignette, turn);
  const double c = fisheye.centre_px();
  std::printf(
      "fisheye camera: %dx%d, f %.3f, c %.3f, k1 %.4f; the source's corners at %.1f deg; vignette %.2f; turned %.1f, "
      "%.1f deg\n",
      size, size, focal, c, k1, fisheye.source_corner_theta_rad() * 180 / M_PI, vignette, turn[0] * 180 / M_PI,
      turn[1] * 180 / M_PI);

  fs::create_directories(out / "cam0" / "data");
  fs::create_directories(out / "grid0" / "cam0" / "data");
  std::ofstream index(out / "cam0" / "data.csv");
  index << "timestamp [ns],filename\n";
  size_t n_corners = 0, n_kept = 0;
  double theta_min = M_PI, theta_max = 0;
  for (const auto& [stem, path] : frames) {
    cv::imwrite((out / "cam0" / "data" / (stem + ".png")).string(),
                fisheye.Image(cv::imread(path.string(), cv::IMREAD_GRAYSCALE)));
    index << stem << "," << stem << ".png\n";
    if (!peers.count(stem)) continue;
    // The peer's corners through the same two cameras.
    const auto corners = ReadPeer(peers[stem]);
    std::vector<cv::Point2d> px;
    for (const auto& pc : corners) px.emplace_back(pc.x, pc.y);
    const std::vector<cv::Point2d> mapped = fisheye.Points(px);
    std::ofstream csv(out / "grid0" / "cam0" / "data" / (stem + ".csv"));
    csv << "#ts,tag_rows,tag_cols,tag_size,tag_spacing,kp_x,kp_y,p_x,p_y,p_z,tag_id,corner_idx\n";
    csv.precision(9);
    for (size_t i = 0; i < corners.size(); ++i) {
      ++n_corners;
      const double x = mapped[i].x, y = mapped[i].y;
      if (x < 2 || y < 2 || x > size - 3 || y > size - 3) continue;
      ++n_kept;
      const double theta = std::hypot(x - c, y - c) / focal;  // k1 = 0: the angle off the axis
      theta_min = std::min(theta_min, theta);
      theta_max = std::max(theta_max, theta);
      csv << corners[i].line_head << "," << x << "," << y << "," << corners[i].line_tail << "\n";
    }
  }
  std::printf("%zu frames; the peer's corners: %zu of %zu inside the fisheye image, %.0f-%.0f deg off its axis\n",
              frames.size(), n_kept, n_corners, theta_min * 180 / M_PI, theta_max * 180 / M_PI);

  // The target (the first *.yaml with calib_target), marked equi4, and the truth.
  for (const auto& e : fs::directory_iterator(dir)) {
    if (e.path().extension() != ".yaml") continue;
    std::ifstream in(e.path());
    std::stringstream text;
    text << in.rdbuf();
    std::string t = text.str();
    if (t.find("calib_target") == std::string::npos && t.find("target_type") == std::string::npos) continue;
    for (const char* from : {"\"radtan4\"", "'radtan4'", "radtan4", "\"radtan\"", "radtan"}) {
      const auto at = t.find(from);
      if (at != std::string::npos) {
        t.replace(at, std::string(from).size(), "\"equi4\"");
        break;
      }
    }
    const auto res = t.find("resolution:");
    if (res != std::string::npos) {
      const auto eol = t.find('\n', res);
      t.replace(res, eol - res, "resolution: [" + std::to_string(size) + ", " + std::to_string(size) + "]");
    }
    std::ofstream(out / e.path().filename()) << t;
    break;
  }
  // ROS camera_info, which calibrate-camera's --calibration and detect read as it is.
  std::ofstream truth(out / "truth.yaml");
  truth.precision(10);
  truth << "# The fisheye camera real_fisheye_warp formed these frames with (OpenCV's pixel convention);\n"
        << "# the source camera's calibration RMS (its error carries into this truth): " << rms << " px.\n"
        << "image_width: " << size << "\nimage_height: " << size << "\ndistortion_model: equidistant\n"
        << "camera_matrix: {rows: 3, cols: 3, data: [" << focal << ", 0, " << c << ", 0, " << focal << ", " << c
        << ", 0, 0, 1]}\n"
        << "distortion_coefficients: {rows: 1, cols: 4, data: [" << k1 << ", 0, 0, 0]}\n";
  return 0;
}
