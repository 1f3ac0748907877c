#pragma once
// `orbcal render`: a rendered calibration dataset (layout: sim/dataset.hpp and the README).
//
//  1. configurations: sim::generateConfigurations on the NOMINAL arm (the planner knows only the
//     nominal model), seed = configuration seed;
//  2. true joints = commanded + N(0, joint noise) (sim::addJointNoise, stream kJointNoiseStream);
//  3. ground truth camera_T_board = sim::cameraTBoard(TRUE arm = nominal + injected errors, q_true);
//  4. that pose rendered (BoardRenderer::render, degradations drawn from makeRng(render seed,
//     kRenderStream + index)), written as images/NNNNNN.png.
// Order on disk: robot.yaml, scene.yaml (verbatim copies of the inputs) and manifest.yaml first; the
// images (PNG-encoded and written on a worker thread while the next frame renders, each atomically);
// samples.csv last, so a dataset without samples.csv is an unfinished run.
// Resume: rerunning with the same inputs into the same folder keeps every image that exists and
// decodes, and renders the rest. Different inputs: refused (InputError naming manifest.yaml) unless
// `force`, which deletes the old images and samples.csv first.
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "orbcal/sim/errors.hpp"
#include "orbcal/sim/io.hpp"

namespace orbcal::render {

inline constexpr std::uint64_t kJointNoiseStream = 0x6a6f696e74ULL;        // "joint"
inline constexpr std::uint64_t kRenderStream = 0x72656e6465720000ULL;      // "render" << 16, + sample index

struct DatasetJob {
  std::string robot = sim::kDefaultRobot;  ///< file or builtin:NAME
  std::string scene = sim::kDefaultScene;
  sim::ErrorSetSpec errors;                ///< injected into the true arm
  int count = 50;
  std::uint64_t configuration_seed = 1;
  std::uint64_t noise_seed = 1;
  std::uint64_t render_seed = 1;
  double joint_noise_sigma_rad = 0.01 * 3.14159265358979323846 / 180.0;
  std::string out;                         ///< dataset folder (created)
  bool force = false;
  int generator_threads = 0;               ///< 0: all hardware threads
  int png_compression = 1;                 ///< 0..9 (cv::IMWRITE_PNG_COMPRESSION): 1 is fast and lossless
};

struct DatasetRunReport {
  int rendered = 0;          ///< images rendered and written by this run
  int skipped = 0;           ///< images already there (resumed)
  bool resumed = false;      ///< the folder held this dataset's manifest
  int msaa_samples = 0;
  std::vector<std::string> warnings;  ///< from the renderer (e.g. MSAA fallback)
  double render_seconds = 0; ///< wall time of the render + write loop
};

/// Progress: (images done including skipped, total). May throw to stop the run (images written so
/// far stay intact; the queued ones are written first).
using DatasetProgress = std::function<void(int done, int total)>;

/// Writes the dataset. Throws sim::InputError naming the file (bad input, unwritable folder, full
/// disk) with every earlier image intact.
DatasetRunReport renderDataset(const DatasetJob& job, const DatasetProgress& progress = {});

}  // namespace orbcal::render
