// Issue #13: a rig.yaml is user input. These are the cases that crashed or wrapped silently before
// the text was checked ahead of OpenCV's parser: each now fails with one line naming the file.
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "voxcap/rig/calibration.hpp"
#include "voxcap/rig/input_file.hpp"

namespace vc::rig {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

fs::path temp_dir() {
  fs::path dir = fs::path(::testing::TempDir()) / "vc_rig_calibration_limits_test";
  fs::create_directories(dir);
  return dir;
}

std::string read_text(const fs::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string error_of(const fs::path& p) {
  try {
    (void)read_calibration(p.string());
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

std::string error_of_text(const std::string& text) {
  try {
    (void)parse_calibration(text, "rig.yaml");
  } catch (const std::runtime_error& e) {
    return e.what();
  }
  return "no error";
}

// A valid one-camera file to damage.
const std::string kGood = R"(%YAML:1.0
---
cam0:
   width: 640
   height: 480
   K: [ 500., 0., 320., 0., 500., 240., 0., 0., 1. ]
   R: [ 1., 0., 0., 0., 1., 0., 0., 0., 1. ]
   t: [ 0., 0., 3. ]
)";

bool one_line(const std::string& s) {
  return s.find('\n') == std::string::npos;
}

TEST(RigCalibrationLimits, GoodTextStillReads) {
  const Calibration c = parse_calibration(kGood, "rig.yaml");
  ASSERT_EQ(c.cameras.size(), 1u);
  EXPECT_EQ(c.cameras[0].width, 640);
}

TEST(RigCalibrationLimits, HundredThousandNestedBracketsAreRefusedBeforeOpenCv) {
  const fs::path p = temp_dir() / "nested.yaml";
  std::ofstream(p) << "%YAML:1.0\n---\ncam0: " << std::string(100000, '[') << "\n";
  const std::string e = error_of(p);
  EXPECT_EQ(e, p.string() + ": line 3: longer than 16384 bytes");  // the issue's file, as it was
  EXPECT_TRUE(one_line(e)) << e;
  // The same brackets one per line: one flow level is all a calibration has.
  std::string lines = "%YAML:1.0\n---\ncam0: [\n";
  for (int d = 0; d < 100000; ++d) lines += "[\n";
  EXPECT_EQ(error_of_text(lines), "rig.yaml: line 4: unexpected '['");
  // Block nesting by indentation and by "- - -" is bounded the same way.
  std::string blocks = "%YAML:1.0\n---\n";
  for (int d = 0; d < 40; ++d)
    blocks += std::string(static_cast<std::size_t>(d), ' ') + "k" + std::to_string(d) + ":\n";
  EXPECT_THAT(error_of_text(blocks), HasSubstr("nested more than 32 levels deep"));
  std::string dashes = "%YAML:1.0\n---\ncam0:\n  ";
  for (int d = 0; d < 40; ++d) dashes += "- ";
  EXPECT_THAT(error_of_text(dashes + "1\n"), HasSubstr("nested more than 32 levels deep"));
}

TEST(RigCalibrationLimits, WidthThatWrapsAnIntIsRefused) {
  std::string text = kGood;
  text.replace(text.find("640"), 3, "99999999999");
  const std::string e = error_of_text(text);
  EXPECT_EQ(e, "rig.yaml: line 4: integer 99999999999 is out of range (at most 2147483647)");
  text = kGood;
  text.replace(text.find("640"), 3, "0x1FFFFFFFF");
  EXPECT_THAT(error_of_text(text), HasSubstr("line 4: integer 0x1FFFFFFFF is out of range"));
  // In range for an int but not an image: the camera check names it.
  text = kGood;
  text.replace(text.find("640"), 3, "2000000000");
  EXPECT_THAT(error_of_text(text), HasSubstr("cam0: image size must be in [1, 16384] pixels"));
  // Reals are not integers: 1e400 is read as inf by OpenCV and refused as not finite.
  text = kGood;
  text.replace(text.find("500.,"), 4, "1e400");
  EXPECT_THAT(error_of_text(text), HasSubstr("cam0.K: values must be finite"));
}

TEST(RigCalibrationLimits, NonRegularFilesAreRefusedWithoutBlocking) {
  const fs::path fifo = temp_dir() / "fifo.yaml";
  fs::remove(fifo);
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_EQ(error_of(fifo), fifo.string() + ": not a regular file (a FIFO)");  // returns: no writer needed
  EXPECT_EQ(error_of(temp_dir()), temp_dir().string() + ": not a regular file (a directory)");
  EXPECT_THAT(error_of("/dev/zero"), HasSubstr("/dev/zero: not a regular file (a character device)"));
  EXPECT_THAT(error_of(temp_dir() / "absent.yaml"), HasSubstr("absent.yaml: no such file"));
  fs::remove(fifo);
}

TEST(RigCalibrationLimits, OnlyTheSubsetOpenCvWritesReachesItsParser) {
  // Inputs the fuzzer found to hang or crash OpenCV 4.6's YAML parser: refused before it.
  EXPECT_EQ(error_of_text("%YAML:1.0\n---dt: d\n 2, -3.785       13pe-op1,\n       1, 3p"),
            "rig.yaml: line 2: text after the document marker ---");
  EXPECT_EQ(error_of_text("%YAML:1.0\n--- dt: d\n 2, 1,\n 1, 3p"),
            "rig.yaml: line 2: text after the document marker ---");
  EXPECT_EQ(error_of_text("%YAML:1.0\n# v0 # vox0 ]\ncam6:\n -  vers0\n...\n# v0:\n -  versionA#]\n"),
            "rig.yaml: line 7: text after the document end marker ... (start a document with ---)");
  EXPECT_EQ(error_of_text("%YAML:1.0\n---\n c\"\"\"\"\"\"\"%YAML:1.0\n"),
            "rig.yaml: line 3: expected 'key: value' or '- value'");
  EXPECT_EQ(error_of_text("%YAML:1.0\n - 0\n--\n-"),
            "rig.yaml: line 2: the top level must be a mapping of keys at column 0");
  EXPECT_EQ(error_of_text(kGood + "   - 1\n"), "rig.yaml: line 9: a '- ' item among the keys of a mapping");
  EXPECT_EQ(error_of_text(kGood + "      deeper: 1\n"),
            "rig.yaml: line 9: more indented than the line before allows");
  EXPECT_EQ(error_of_text(kGood + "grid: { nx: 1 }\n"), "rig.yaml: line 9: unexpected '{'");
  EXPECT_EQ(error_of_text(kGood + "grid: [ 1, 2\n"), "rig.yaml: line 9: a '[' is not closed");
  EXPECT_EQ(error_of_text(kGood + "name: \"a\\nb\"\n"),
            "rig.yaml: line 9: escapes and control characters are not allowed in strings");
  // What OpenCV writes, comments, a quoted name and a name with spaces still read.
  std::string text = kGood;
  text.insert(text.find("   width"), "   # the first camera\n   name: front left\n");
  EXPECT_EQ(parse_calibration(text, "rig.yaml").cameras[0].name, "front left");
  text = kGood;
  text.insert(text.find("   width"), "   name: \"cam: 0\"\n");
  EXPECT_EQ(parse_calibration(text, "rig.yaml").cameras[0].name, "cam: 0");
}

TEST(RigCalibrationLimits, SizeNulAndLineLengthAreBounded) {
  const fs::path big = temp_dir() / "big.yaml";
  {
    std::ofstream out(big);
    out << kGood;
    out << std::string(kMaxCalibrationBytes, '#');
  }
  EXPECT_THAT(error_of(big), HasSubstr("larger than 4194304 bytes"));
  fs::remove(big);
  EXPECT_THAT(error_of_text(kGood + std::string("x: 1\0", 5)), HasSubstr("contains a NUL byte"));
  EXPECT_THAT(error_of_text(kGood + "name: " + std::string(kMaxYamlLine, 'a') + "\n"),
              HasSubstr("longer than 16384 bytes"));
}

TEST(RigCalibrationLimits, EveryExampleRigPassesTheLimits) {
  for (const char* name : {"emulated.yaml", "ftdi-box.yaml", "pi5-gpiod.yaml"}) {
    const fs::path p = fs::path(VOXCAP_SOURCE_DIR) / "hw/rigs" / name;
    EXPECT_NO_THROW(check_yaml_limits(read_text(p), p.string())) << name;
    EXPECT_EQ(error_of(p), "no error") << name;
  }
}

}  // namespace
}  // namespace vc::rig
