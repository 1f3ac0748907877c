#include <filesystem>

#include "bench.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/render/renderer.hpp"
#include "orbcal/render/settings.hpp"
#include "orbcal/sim/io.hpp"

namespace orbcal::tools {

namespace {
void benchRender() {
  const sim::Scene scene = sim::loadScene(sim::kDefaultScene);
  const render::RenderSettings settings = render::loadRenderSettings(sim::kDefaultScene);
  {
    render::BoardRenderer renderer(scene, settings);
    Eigen::Isometry3d camera_T_board = Eigen::Isometry3d::Identity();
    camera_T_board.translation() = Eigen::Vector3d(-0.3, -0.2, 2.0);
    renderer.renderClean(camera_T_board);  // warm-up: LLVM JIT, framebuffer allocation
    const auto t = timeRepeats(30, [&] { renderer.renderClean(camera_T_board); });
    printFigure("render one " + std::to_string(scene.camera.width_px) + "x" + std::to_string(scene.camera.height_px) +
                    " frame, MSAA " + std::to_string(renderer.msaaSamples()) + "x, readback",
                t, "ms", 1e3, "(notes measured 23-44 ms)", "");
  }
  const std::string out = (std::filesystem::temp_directory_path() / "orbcal-bench-render").string();
  render::DatasetJob job;
  job.count = 250;
  job.out = out;
  job.force = true;
  std::filesystem::remove_all(out);
  render::DatasetRunReport report;
  const auto t = timeRepeats(1, [&] { report = render::renderDataset(job); });
  printFigure("orbcal render: 250 images 1280x1024 MSAA " + std::to_string(report.msaa_samples) + "x (whole run)", t, "s ",
              1.0, "< 20 s");
  std::printf("  %-58s %9.3f ms per image (render + PNG written on a worker thread)\n", "render + write loop only",
              1e3 * report.render_seconds / report.rendered);
  std::filesystem::remove_all(out);
}
}  // namespace

ORBCAL_BENCH("render", benchRender);

}  // namespace orbcal::tools
