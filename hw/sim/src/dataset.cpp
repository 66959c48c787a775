// Dataset writer: renders every (frame, camera) on a small pool of threads (the Scene is
// thread-safe) and writes images and truth files; the CSVs are written in frame order.
#include "voxcap/sim/dataset.hpp"

#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>
#include <stdexcept>
#include <thread>

#include <opencv2/core/persistence.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "voxcap/body/bvh.hpp"
#include "voxcap/body/glm_cv.hpp"

namespace vc::sim {
namespace {

namespace fs = std::filesystem;

void write_png(const fs::path& path, const cv::Mat& img, int compression) {
  cv::Mat out;
  if (img.channels() == 3) {
    cv::cvtColor(img, out, cv::COLOR_RGB2BGR);
  } else {
    out = img;
  }
  bool ok = false;
  try {
    ok = cv::imwrite(path.string(), out, {cv::IMWRITE_PNG_COMPRESSION, compression});
  } catch (const cv::Exception& e) {
    throw std::runtime_error(path.string() + ": cannot write (" + e.msg + ")");
  }
  if (!ok) throw std::runtime_error(path.string() + ": cannot write");
}

void make_dirs(const fs::path& p) {
  std::error_code ec;
  fs::create_directories(p, ec);
  if (ec) throw std::runtime_error(p.string() + ": cannot create directory (" + ec.message() + ")");
}

std::ofstream open_text(const fs::path& p) {
  std::ofstream f(p, std::ios::binary);
  if (!f) throw std::runtime_error(p.string() + ": cannot open for writing");
  return f;
}

void write_scene_yaml(const fs::path& p, const Scene& scene, int frames, int backgrounds) {
  const SceneOptions& o = scene.options();
  cv::FileStorage fs;
  if (!fs.open(p.string(), cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML)) {
    throw std::runtime_error(p.string() + ": cannot open for writing");
  }
  fs.writeComment("How this sequence was rendered by voxcap's virtual rig (hw/sim).");
  fs << "motion" << o.motion.source << "fps" << o.motion.fps << "frames" << frames << "lead_in_frames"
     << scene.motion().lead_in_frames() << "backgrounds" << backgrounds << "seed"
     << static_cast<double>(o.seed) << "noise_sigma" << o.noise_sigma << "flicker" << o.flicker
     << "appearance" << o.appearance << "room" << o.room << "shadows" << static_cast<int>(o.shadows)
     << "shadow_factor" << o.shadow_factor << "body_height_m" << o.body.height_m;
  if (const BvhMapping* m = scene.motion().bvh()) {
    fs << "bvh"
       << "{";
    fs << "convention" << m->convention << "scale" << m->scale << "R_world_from_file"
       << cv::Mat(vc::body::to_cv(m->R_world_from_file)) << "t_world_m"
       << cv::Mat(vc::body::to_cv(m->t_world_m)) << "frame_time_s" << m->frame_time_s << "first_frame"
       << m->first_frame;
    fs << "}";
  }
  fs.release();
}

}  // namespace

bool DatasetOptions::valid(std::string* why) const {
  std::ostringstream os;
  if (frames < 0 || frames > 1000000) {
    os << "frames must be in [0, 1000000] (0: the motion's length), got " << frames;
  } else if (backgrounds < 0 || backgrounds > 100000) {
    os << "backgrounds must be in [0, 100000], got " << backgrounds;
  } else if (png_compression < 0 || png_compression > 9) {
    os << "png_compression must be in [0, 9]";
  } else if (threads < 0 || threads > 256) {
    os << "threads must be in [0, 256]";
  } else {
    return true;
  }
  if (why) *why = os.str();
  return false;
}

DatasetSummary write_dataset(const Scene& scene, const DatasetOptions& opt, const std::string& dir_name) {
  std::string why;
  if (!opt.valid(&why)) throw std::invalid_argument("dataset: " + why);
  const auto t0 = std::chrono::steady_clock::now();
  const fs::path dir(dir_name);
  const int cams = scene.camera_count();
  const int frames = opt.frames > 0 ? opt.frames : scene.motion().natural_frames();
  DatasetSummary sum;
  sum.frames = frames;
  sum.cameras = cams;
  sum.backgrounds = opt.backgrounds;

  make_dirs(dir / "truth" / "silhouettes");
  for (int k = 0; k < cams; ++k) {
    const std::string ck = "cam" + std::to_string(k);
    make_dirs(dir / ck);
    make_dirs(dir / "background" / ck);
    make_dirs(dir / "truth" / "silhouettes" / ck);
    if (opt.shadows) make_dirs(dir / "truth" / "shadows" / ck);
  }
  rig::write_calibration((dir / "rig.yaml").string(), scene.calibration());
  write_scene_yaml(dir / "truth" / "scene.yaml", scene, frames, opt.backgrounds);
  sum.files += 2;

  // Truth tables, in frame order.
  {
    std::ofstream joints = open_text(dir / "truth" / "joints.csv");
    std::ofstream feats = open_text(dir / "truth" / "features.csv");
    joints << "frame,joint,x,y,z\n";
    feats << "frame,camera,feature,u,v,visible\n";
    char buf[200];
    for (int f = 0; f < frames; ++f) {
      const auto p = scene.joints(f);
      for (int j = 0; j < kJointCount; ++j) {
        const cv::Vec3d& v = p[static_cast<std::size_t>(j)];
        std::snprintf(buf, sizeof buf, "%d,%s,%.6f,%.6f,%.6f\n", f, std::string(joint_name(j)).c_str(), v[0],
                      v[1], v[2]);
        joints << buf;
      }
      for (int k = 0; k < cams; ++k) {
        for (const FeatureTruth& t : scene.features(f, k)) {
          std::snprintf(buf, sizeof buf, "%d,%d,%s,%.4f,%.4f,%d\n", f, k,
                        std::string(feature_name(t.feature)).c_str(), t.uv.x, t.uv.y, t.visible ? 1 : 0);
          feats << buf;
        }
      }
    }
    if (!joints || !feats)
      throw std::runtime_error((dir / "truth").string() + ": write error in the CSV files");
    sum.files += 2;
  }
  if (opt.motion_bvh) {
    std::vector<Pose> poses;
    poses.reserve(static_cast<std::size_t>(frames));
    for (int f = 0; f < frames; ++f) poses.push_back(scene.motion().skeleton_pose(f));
    try {
      vc::body::write_bvh((dir / "truth" / "motion.bvh").string(), scene.motion().skeleton(), poses,
                          1.0 / scene.fps());
      ++sum.files;
    } catch (const std::invalid_argument& e) {
      sum.notes.push_back(std::string("truth/motion.bvh not written: ") + e.what());
    }
  }

  // Images: backgrounds then frames, as (index, camera) work items over a thread pool.
  const long bg_items = static_cast<long>(opt.backgrounds) * cams;
  const long total = bg_items + static_cast<long>(frames) * cams;
  std::atomic<long> next{0};
  std::atomic<long> done{0};
  std::atomic<long long> render_ns{0};
  std::mutex mu;
  std::exception_ptr error;
  auto worker = [&] {
    cv::Mat rgb, sil, shadow;
    for (;;) {
      const long item = next.fetch_add(1);
      if (item >= total) return;
      {
        std::lock_guard<std::mutex> lock(mu);
        if (error) return;
      }
      try {
        if (item < bg_items) {
          const int i = static_cast<int>(item / cams), k = static_cast<int>(item % cams);
          scene.render_background(k, i, rgb);
          write_png(dir / "background" / ("cam" + std::to_string(k)) / (std::to_string(i) + ".png"), rgb,
                    opt.png_compression);
        } else {
          const long fi = item - bg_items;
          const int f = static_cast<int>(fi / cams), k = static_cast<int>(fi % cams);
          const std::string ck = "cam" + std::to_string(k), name = std::to_string(f) + ".png";
          const auto r0 = std::chrono::steady_clock::now();
          scene.render(f, k, rgb, &sil, opt.shadows ? &shadow : nullptr);
          render_ns +=
              std::chrono::duration_cast<std::chrono::nanoseconds>(std::chrono::steady_clock::now() - r0)
                  .count();
          write_png(dir / ck / name, rgb, opt.png_compression);
          write_png(dir / "truth" / "silhouettes" / ck / name, sil, opt.png_compression);
          if (opt.shadows) write_png(dir / "truth" / "shadows" / ck / name, shadow, opt.png_compression);
        }
        const long d = ++done;
        if (opt.progress) {
          std::lock_guard<std::mutex> lock(mu);
          opt.progress(static_cast<int>(d), static_cast<int>(total));
        }
      } catch (...) {
        std::lock_guard<std::mutex> lock(mu);
        if (!error) error = std::current_exception();
        return;
      }
    }
  };
  const int n_threads = std::max(
      1, std::min<int>(opt.threads > 0 ? opt.threads : static_cast<int>(std::thread::hardware_concurrency()),
                       64));
  std::vector<std::thread> pool;
  for (int t = 1; t < n_threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (error) std::rethrow_exception(error);

  sum.files += static_cast<std::size_t>(bg_items) +
               static_cast<std::size_t>(frames) * static_cast<std::size_t>(cams) * (opt.shadows ? 3u : 2u);
  sum.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  const long frame_items = static_cast<long>(frames) * cams;
  sum.render_ms_per_image =
      frame_items > 0 ? static_cast<double>(render_ns.load()) * 1e-6 / static_cast<double>(frame_items) : 0;
  return sum;
}

}  // namespace vc::sim
