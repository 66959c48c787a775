// libFuzzer target for the calibration importers (a file handed to voxcap calib import is user input):
// the first byte picks the format, the rest is the file. parse_import must either return a calibration
// that valid() accepts or throw std::runtime_error (ImportError) with one line, never crash, hang,
// overflow the stack or read out of bounds.
#include <cstddef>
#include <cstdint>
#include <stdexcept>
#include <string>

#include <opencv2/core.hpp>

#include "voxcap/calib/import.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  static constexpr vc::calib::Format kFormats[] = {vc::calib::Format::OpenCV, vc::calib::Format::Qualisys,
                                                   vc::calib::Format::Panoptic, vc::calib::Format::Toml,
                                                   vc::calib::Format::Middlebury};
  static constexpr const char* kNames[] = {"fuzz.yaml", "fuzz.qca", "fuzz.json", "fuzz.toml", "fuzz_par.txt"};
  const int f = data[0] % 5;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  vc::calib::ImportOptions options;
  options.image_size = cv::Size(640, 480);  // Middlebury: never look for images beside the file
  try {
    const vc::calib::Imported imp = vc::calib::parse_import(kFormats[f], text, kNames[f], options);
    std::string why;
    if (!imp.calibration.valid(&why)) __builtin_trap();
  } catch (const std::runtime_error& e) {
    if (std::string(e.what()).find('\n') != std::string::npos) __builtin_trap();
  }
  return 0;
}
