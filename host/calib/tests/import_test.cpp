// The importers against hand-made files whose answer is known. Every file below describes the same
// camera, written in its format's own units and axes:
//
//   voxcap frame (metres, z up): centre C = (0, -3, 1), looking along +y, image x = world +x, image y =
//   world -z; R_cam_from_world = [1 0 0; 0 0 -1; 0 1 0], t = -R C = (0, 1, 3); 640x480, f = 1000 px,
//   principal point (320, 240), no distortion.
//
// so the world point P = (0.3, 0, 1.6) is at x_cam = (0.3, -0.6, 3): pixel (420, 40), and the floor
// point (0, 0, 0) at x_cam = (0, 1, 3): pixel (320, 573.33). Each import must give exactly that camera.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "voxcap/calib/import.hpp"
#include "voxcap/rig/calibration.hpp"

namespace vc::calib {
namespace {

namespace fs = std::filesystem;

const cv::Matx33d kR(1, 0, 0, 0, 0, -1, 0, 1, 0);
const cv::Vec3d kT(0, 1, 3);

void expect_known_camera(const rig::Camera& c, double tol = 1e-9) {
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  EXPECT_NEAR(c.K(0, 0), 1000, 1e-9);
  EXPECT_NEAR(c.K(1, 1), 1000, 1e-9);
  EXPECT_NEAR(c.K(0, 2), 320, 1e-9);
  EXPECT_NEAR(c.K(1, 2), 240, 1e-9);
  for (int i = 0; i < 9; ++i) EXPECT_NEAR(c.R_cam_from_world.val[i], kR.val[i], tol) << "R entry " << i;
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(c.t_cam_from_world[i], kT[i], tol) << "t entry " << i;
  const cv::Point2d p = c.project(cv::Vec3d(0.3, 0, 1.6));
  EXPECT_NEAR(p.x, 420, 1e-6);
  EXPECT_NEAR(p.y, 40, 1e-6);
  const cv::Point2d floor = c.project(cv::Vec3d(0, 0, 0));
  EXPECT_NEAR(floor.x, 320, 1e-6);
  EXPECT_NEAR(floor.y, 240 + 1000.0 / 3.0, 1e-6);
  const cv::Vec3d C = c.center_world();
  EXPECT_NEAR(C[0], 0, tol);
  EXPECT_NEAR(C[1], -3, tol);
  EXPECT_NEAR(C[2], 1, tol);
}

// import -> write_calibration -> read_calibration gives the same cameras.
void expect_round_trip(const rig::Calibration& cal, const std::string& tag) {
  const fs::path dir = fs::temp_directory_path() / ("vc_calib_rt_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  const std::string path = (dir / (tag + ".yaml")).string();
  rig::write_calibration(path, cal);
  const rig::Calibration back = rig::read_calibration(path);
  ASSERT_EQ(back.cameras.size(), cal.cameras.size());
  for (std::size_t i = 0; i < cal.cameras.size(); ++i) {
    const rig::Camera &a = cal.cameras[i], &b = back.cameras[i];
    EXPECT_EQ(a.name, b.name);
    EXPECT_EQ(a.width, b.width);
    EXPECT_EQ(a.height, b.height);
    for (int k = 0; k < 9; ++k) EXPECT_DOUBLE_EQ(a.K.val[k], b.K.val[k]);
    for (int k = 0; k < 5; ++k) EXPECT_DOUBLE_EQ(a.dist[k], b.dist[k]);
    for (int k = 0; k < 9; ++k) EXPECT_DOUBLE_EQ(a.R_cam_from_world.val[k], b.R_cam_from_world.val[k]);
    for (int k = 0; k < 3; ++k) EXPECT_DOUBLE_EQ(a.t_cam_from_world[k], b.t_cam_from_world[k]);
  }
  fs::remove_all(dir);
}

Imported parse(Format f, const std::string& text, const std::string& path, ImportOptions o = {}) {
  return parse_import(f, text, path, o);
}

// Qualisys: R_qca = diag(1,-1,-1) R, the centre in mm, K x64 on the sensor; fov_video offset (8, 4).
const char* kQca = R"(<?xml version='1.0' encoding='ASCII'?>
<calibration type="regular">
  <cameras>
    <camera active="1" serial="front" viewrotation="0">
      <fov_marker bottom="483" left="8" right="647" top="4"/>
      <fov_video bottom="483" left="8" right="647" top="4"/>
      <transform r11="1" r12="0" r13="0" r21="0" r22="0" r23="1" r31="0" r32="-1" r33="0" x="0" y="-3000" z="1000"/>
      <intrinsic centerPointU="20992" centerPointV="15616" focalLengthU="64000" focalLengthV="64000" radialDistortion1="0" radialDistortion2="0" radialDistortion3="0" skew="0" tangentalDistortion1="0" tangentalDistortion2="0"/>
    </camera>
  </cameras>
</calibration>
)";

TEST(CalibImport, QualisysUnitsAxesAndSensorOffset) {
  const Imported imp = parse(Format::Qualisys, kQca, "hand.qca");
  ASSERT_EQ(imp.calibration.cameras.size(), 1u);
  EXPECT_EQ(imp.calibration.cameras[0].name, "front");
  expect_known_camera(imp.calibration.cameras[0]);
  EXPECT_EQ(imp.report.rotations_fixed, 0);
  expect_round_trip(imp.calibration, "qca");
}

// Panoptic: centimetres, up -y. The same camera is R = I, t = (0, 100, 300) cm there
// (p_panoptic = (100 x, -100 z, 100 y)).
const char* kPanoptic = R"({"calibDataSource": "hand", "cameras": [
  {"name": "00_07", "type": "hd", "resolution": [640, 480],
   "K": [[1000, 0, 320], [0, 1000, 240], [0, 0, 1]], "distCoef": [0, 0, 0, 0, 0],
   "R": [[1, 0, 0], [0, 1, 0], [0, 0, 1]], "t": [[0], [100], [300]]}]})";

TEST(CalibImport, PanopticCentimetresAndUpMinusY) {
  const Imported imp = parse(Format::Panoptic, kPanoptic, "hand.json");
  ASSERT_EQ(imp.calibration.cameras.size(), 1u);
  EXPECT_EQ(imp.calibration.cameras[0].name, "00_07");
  expect_known_camera(imp.calibration.cameras[0]);
  expect_round_trip(imp.calibration, "panoptic");
}

// Pose2Sim TOML: Rodrigues rotation (+90 degrees about x), metres; the same file in mm with --units mm.
std::string toml_text(const char* translation) {
  return std::string(R"([cam_1]
name = "cam01"
size = [ 640.0, 480.0]
matrix = [ [ 1000.0, 0.0, 320.0], [ 0.0, 1000.0, 240.0], [ 0.0, 0.0, 1.0]]
distortions = [ 0.0, 0.0, 0.0, 0.0]
rotation = [ 1.5707963267948966, 0.0, 0.0]
translation = )") +
         translation + R"(
fisheye = false

[metadata]
adjusted = false
error = 0.0
)";
}

TEST(CalibImport, TomlRodriguesAndUnits) {
  const Imported m = parse(Format::Toml, toml_text("[ 0.0, 1.0, 3.0]"), "hand.toml");
  ASSERT_EQ(m.calibration.cameras.size(), 1u);
  EXPECT_EQ(m.calibration.cameras[0].name, "cam01");
  expect_known_camera(m.calibration.cameras[0], 1e-12);
  ImportOptions mm;
  mm.unit_m = 0.001;
  const Imported b = parse(Format::Toml, toml_text("[ 0.0, 1000.0, 3000.0]"), "hand.toml", mm);
  expect_known_camera(b.calibration.cameras[0], 1e-12);
  expect_round_trip(b.calibration, "toml");
  EXPECT_THROW(parse(Format::Toml,
                     toml_text("[ 0.0, 1.0, 3.0]\nfisheye2 = 1") + "[cam_2]\nmatrix = 1\nfisheye = true\n",
                     "hand.toml"),
               ImportError);
}

// Middlebury: P = K [R | t], the frame kept; this copy's header line skipped; image size given.
TEST(CalibImport, MiddleburyKeepsItsFrameAndFixesPrintPrecision) {
  const std::string line = "view1.png 1000 0 320 0 1000 240 0 0 1 1 0 0 0 0 -1 0 1 0 0 1 3\n";
  ImportOptions o;
  o.image_size = cv::Size(640, 480);
  const Imported imp = parse(Format::Middlebury, "imgname.png k11 k12 k13 ...\n" + line, "hand_par.txt", o);
  ASSERT_EQ(imp.calibration.cameras.size(), 1u);
  EXPECT_EQ(imp.calibration.cameras[0].name, "view1");
  expect_known_camera(imp.calibration.cameras[0]);
  EXPECT_EQ(imp.report.rotations_fixed, 0);
  // The original's first line is the image count.
  EXPECT_EQ(parse(Format::Middlebury, "1\n" + line, "hand_par.txt", o).calibration.cameras.size(), 1u);
  EXPECT_THROW(parse(Format::Middlebury, "2\n" + line, "hand_par.txt", o), ImportError);

  // R printed to ~6 digits (an entry off by 2e-6, over hw/rig's 1e-6): re-orthonormalised, reported.
  const std::string rough = "view1.png 1000 0 320 0 1000 240 0 0 1 1.000002 0 0 0 0 -1 0 1 0 0 1 3\n";
  const Imported fixed = parse(Format::Middlebury, rough, "hand_par.txt", o);
  EXPECT_EQ(fixed.report.rotations_fixed, 1);
  EXPECT_NEAR(fixed.report.max_rotation_change, 2e-6, 1e-9);
  EXPECT_NEAR(fixed.report.max_rotation_error, 4e-6, 1e-8);
  EXPECT_EQ(fixed.report.worst_rotation_camera, "view1");
  expect_known_camera(fixed.calibration.cameras[0], 1e-12);

  // Far from a rotation, or a reflection: refused, one line naming the camera.
  const std::string far = "view1.png 1000 0 320 0 1000 240 0 0 1 1.1 0 0 0 0 -1 0 1 0 0 1 3\n";
  try {
    parse(Format::Middlebury, far, "hand_par.txt", o);
    FAIL() << "a rotation 0.1 off was accepted";
  } catch (const ImportError& e) {
    EXPECT_NE(std::string(e.what()).find("camera 'view1'"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("not a rotation"), std::string::npos) << e.what();
  }
  const std::string mirror = "view1.png 1000 0 320 0 1000 240 0 0 1 -1 0 0 0 0 -1 0 1 0 0 1 3\n";
  EXPECT_THROW(parse(Format::Middlebury, mirror, "hand_par.txt", o), ImportError);
}

// OpenCV: the calibration sample's single camera, a per-camera map file in YAML and the same in XML.
TEST(CalibImport, OpenCvLayouts) {
  const std::string yaml = R"(%YAML:1.0
---
front:
   image_width: 640
   image_height: 480
   camera_matrix: !!opencv-matrix
      rows: 3
      cols: 3
      dt: d
      data: [ 1000., 0., 320., 0., 1000., 240., 0., 0., 1. ]
   distortion_coefficients: !!opencv-matrix
      rows: 1
      cols: 5
      dt: d
      data: [ 0., 0., 0., 0., 0. ]
   rvec: [ 1.5707963267948966, 0., 0. ]
   tvec: [ 0., 1000., 3000. ]
)";
  ImportOptions mm;
  mm.unit_m = 0.001;
  const Imported y = parse(Format::OpenCV, yaml, "hand.yaml", mm);
  ASSERT_EQ(y.calibration.cameras.size(), 1u);
  EXPECT_EQ(y.calibration.cameras[0].name, "front");
  expect_known_camera(y.calibration.cameras[0], 1e-12);

  const std::string xml = R"(<?xml version="1.0"?>
<opencv_storage>
<cam0>
  <name>front</name>
  <width>640</width>
  <height>480</height>
  <K type_id="opencv-matrix"><rows>3</rows><cols>3</cols><dt>d</dt>
    <data>1000. 0. 320. 0. 1000. 240. 0. 0. 1.</data></K>
  <R type_id="opencv-matrix"><rows>3</rows><cols>3</cols><dt>d</dt>
    <data>1. 0. 0. 0. 0. -1. 0. 1. 0.</data></R>
  <t type_id="opencv-matrix"><rows>3</rows><cols>1</cols><dt>d</dt>
    <data>0. 1. 3.</data></t>
</cam0>
</opencv_storage>
)";
  const Imported x = parse(Format::OpenCV, xml, "hand.xml");
  ASSERT_EQ(x.calibration.cameras.size(), 1u);
  EXPECT_EQ(x.calibration.cameras[0].name, "front");
  expect_known_camera(x.calibration.cameras[0]);
  expect_round_trip(x.calibration, "xml");

  // voxcap's own rig.yaml imports as itself.
  const fs::path dir = fs::temp_directory_path() / ("vc_calib_cv_" + std::to_string(::getpid()));
  fs::create_directories(dir);
  rig::write_calibration((dir / "rig.yaml").string(), x.calibration);
  const Imported self = import_calibration(Format::OpenCV, (dir / "rig.yaml").string());
  expect_known_camera(self.calibration.cameras[0]);
  fs::remove_all(dir);
}

// Hostile input: one line, never a crash.
TEST(CalibImport, HostileInputIsOneLine) {
  const auto one_line_error = [](Format f, const std::string& text, const std::string& path) {
    ImportOptions o;
    o.image_size = cv::Size(640, 480);
    try {
      parse(f, text, path, o);
    } catch (const ImportError& e) {
      EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos) << e.what();
      EXPECT_EQ(std::string(e.what()).rfind(path, 0), 0u) << e.what();
      return;
    }
    ADD_FAILURE() << "accepted: " << text.substr(0, 80);
  };
  one_line_error(Format::Panoptic, std::string(100000, '['), "deep.json");
  one_line_error(Format::Toml, "a = " + std::string(100000, '['), "deep.toml");
  one_line_error(Format::Qualisys, std::string(100000, '<'), "deep.qca");
  std::string nested;
  for (int i = 0; i < 100; ++i) nested += "<a>";
  one_line_error(Format::Qualisys, nested, "nested.qca");
  one_line_error(Format::Qualisys, "<!DOCTYPE x [<!ENTITY a \"b\">]><calibration/>", "doctype.qca");
  one_line_error(Format::OpenCV, "<?xml version=\"1.0\"?>\n<!DOCTYPE x><opencv_storage/>", "doctype.xml");
  one_line_error(
      Format::Panoptic,
      R"({"cameras": [{"name": "a", "resolution": [640, 480], "K": [[1e999, 0, 1], [0, 1, 1], [0, 0, 1]], "R": [[1,0,0],[0,1,0],[0,0,1]], "t": [0,0,0]}]})",
      "inf.json");
  one_line_error(
      Format::Panoptic,
      R"({"cameras": [{"name": "a", "resolution": [99999999999, 480], "K": [[1, 0, 1], [0, 1, 1], [0, 0, 1]], "R": [[1,0,0],[0,1,0],[0,0,1]], "t": [0,0,0]}]})",
      "huge.json");
  one_line_error(Format::Middlebury, "v.png 1000 0 320 0 1000 240 0 0 1 1 0 0 0 0 -1 0 1 0 0 1 nan\n",
                 "nan_par.txt");
  one_line_error(Format::Middlebury, "v.png 1000 0 320 0 1000 240 0 0 1 1 0 0 0 0 -1 0 1 0 0 1\n",
                 "short_par.txt");
  one_line_error(Format::Toml, toml_text("[ 0.0, 1.0, inf]"), "inf.toml");
  one_line_error(Format::OpenCV, "%YAML:1.0\n---\nK: " + std::string(100, '['), "deep.yaml");
  one_line_error(Format::Qualisys,
                 std::string(kQca).replace(std::string(kQca).find("r11=\"1\""), 7, "r11=\"x\""), "nan.qca");
  std::string many = "<calibration><cameras>";
  for (int i = 0; i <= kMaxImportCameras; ++i)
    many +=
        "<camera serial=\"c" + std::to_string(i) +
        "\"><fov_video bottom=\"479\" left=\"0\" right=\"639\" top=\"0\"/><transform r11=\"1\" r12=\"0\" "
        "r13=\"0\" "
        "r21=\"0\" r22=\"-1\" r23=\"0\" r31=\"0\" r32=\"0\" r33=\"-1\" x=\"0\" y=\"0\" "
        "z=\"1000\"/><intrinsic "
        "centerPointU=\"20480\" centerPointV=\"15360\" focalLengthU=\"64000\" focalLengthV=\"64000\" "
        "radialDistortion1=\"0\" radialDistortion2=\"0\" radialDistortion3=\"0\" tangentalDistortion1=\"0\" "
        "tangentalDistortion2=\"0\"/></camera>";
  many += "</cameras></calibration>";
  one_line_error(Format::Qualisys, many, "many.qca");
  one_line_error(Format::Middlebury, "", "empty_par.txt");
}

TEST(CalibImport, FormatNames) {
  for (const char* n : {"opencv", "qualisys", "panoptic", "toml", "middlebury"}) {
    const auto f = parse_format(n);
    ASSERT_TRUE(f.has_value()) << n;
    EXPECT_STREQ(format_name(*f), n);
  }
  EXPECT_FALSE(parse_format("colmap").has_value());
}

// Every format is text: a NUL byte is refused before any parser sees it (OpenCV's FileStorage read
// "<?xml version=" followed by NULs as a C string and crashed: calib_fuzz_import's find).
TEST(CalibImport, ANulByteIsNotACalibrationFile) {
  const std::string xml = std::string("<?xml version=") + std::string(80, '\0') +
                          "\"1.0\"?>\n<opencv_storage>\n<width>640</width>\n</opencv_storage>\n";
  for (Format f : {Format::OpenCV, Format::Qualisys, Format::Panoptic, Format::Toml, Format::Middlebury}) {
    try {
      parse(f, xml, "cal.xml", ImportOptions{});
      ADD_FAILURE() << "a file with NUL bytes was accepted";
    } catch (const ImportError& e) {
      EXPECT_NE(std::string(e.what()).find("a NUL byte at offset 14"), std::string::npos) << e.what();
    }
  }
}

}  // namespace
}  // namespace vc::calib
