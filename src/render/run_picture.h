// Pictures of a run directory: which frame (first, nearest a time, the K-th clog, last), its
// contact frame, the silo from run.json, and the scene; and a movie of every frame through
// ffmpeg. What `campaign snapshot`, `campaign movie` and the report's pictures call.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

#include "render/scene.h"

namespace granary::render {

struct FramePick {
  enum Kind { kFirst, kTime, kClog, kLast } kind = kLast;
  double time = 0;  // kTime
  int clog = 1;     // kClog: 1-based
};

struct PictureOptions {
  FramePick pick;
  Colour colour = Colour::kSpecies;
  bool forces = false;
  std::set<std::int64_t> highlight;
  std::vector<Mark> marks;
  std::optional<Window> window;  // a zoom; else the silo's window (RunScene, ClogScene's default)
};

// What a picture of a run needs besides the frame: the silo, its window, species names.
struct RunSetting {
  silo::SiloOutline silo;
  Window window;
  std::vector<std::string> species;
  bool has_contacts = false;
};
// Throws std::runtime_error when the run has no frames (output.frame_interval = 0) or no spec.
RunSetting SettingOf(const rundir::RunData& run);

// The scene of the picked frame; throws std::runtime_error saying what is missing (no frames,
// no contact frames for --forces / force colours, fewer clogs than asked for). The K-th clog is
// the K-th the engine kept (ClogScene) when the run has clog files, else the K-th of the exit
// stream.
Scene RunScene(const std::filesystem::path& run_dir, const PictureOptions& options);

// The K-th (1-based) clogged configuration the engine kept (clog_frames.dump, with its contact
// forces from clog_contacts.dump), in `window` or else the silo's; needs no frames.dump.
Scene ClogScene(const std::filesystem::path& run_dir, int clog, const PictureOptions& options,
                const std::optional<Window>& window = std::nullopt);

// Every frame through ffmpeg into an H.264 MP4 (`fps` frames per second, `width_px` wide);
// `progress(done, total)` after each frame. Returns the number of frames written; throws
// std::runtime_error with ffmpeg's last lines if it fails.
int WriteMovie(const std::filesystem::path& run_dir, const PictureOptions& options, const std::filesystem::path& out,
               int width_px, int fps, const std::function<void(int, int)>& progress);

}  // namespace granary::render
