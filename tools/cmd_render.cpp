// `orbcal render`: a rendered calibration dataset (render/dataset_writer.hpp; layout in docs/file-formats.md).
#include <cstdio>
#include <iostream>
#include <memory>

#include "cli.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/dataset.hpp"
#include "orbcal/sim/se3.hpp"
#include "progress.hpp"

namespace orbcal::tools {

namespace {
void addRenderCommand(CLI::App& app) {
  struct Opts {
    ArmSceneOptions as;
    render::DatasetJob job;
    std::uint64_t seed = 1;
    double joint_noise_deg = 0.01;
    double error_angle_sigma_deg = 0.3;
    double error_length_sigma_mm = 1.0;
    std::string shard;
  };
  auto opt = std::make_shared<Opts>();
  CLI::App* cmd = app.add_subcommand(
      "render",
      "Render a calibration dataset: configurations on the nominal arm, the true arm (nominal + injected errors and effects) "
      "at the noisy plant joints, and the eye-in-hand camera's images of the board (OSMesa, no display or GPU). "
      "Rerunning with the same inputs resumes: finished images are kept.");
  addArmSceneOptions(*cmd, opt->as);
  cmd->add_option("--errors", opt->job.errors.name,
                  "errors injected into the true arm: table3, zero, random, or an error-set file (YAML: DH errors + "
                  "effects; docs/rendered-datasets-and-images.md)")
      ->capture_default_str();
  cmd->add_option("--error-seed", opt->job.errors.seed, "seed of --errors random")->capture_default_str();
  cmd->add_option("--error-angle-sigma-deg", opt->error_angle_sigma_deg, "spread of random theta/alpha errors [deg]")
      ->capture_default_str();
  cmd->add_option("--error-length-sigma-mm", opt->error_length_sigma_mm, "spread of random a/d errors [mm]")
      ->capture_default_str();
  CLI::Option* count = cmd->add_option("-n,--count", opt->job.count, "number of samples (configurations and images)")
                           ->capture_default_str()
                           ->check(CLI::Range(1, 1000000));
  cmd->add_option("--configs", opt->job.configs,
                  "render these configurations, in order, instead of planned ones: a CSV with columns index (optional) and "
                  "q1_rad..qN_rad (or qJ_deg in degrees, qJ_m for a prismatic joint), as `orbcal configs` writes, or "
                  "flange poses (the controller's base_T_flange: flange_x_m, flange_y_m, flange_z_m, flange_qw, flange_qx, "
                  "flange_qy, flange_qz; no joint or link acts, and DIR/images.yaml describes the views for "
                  "`orbcal calibrate` and `orbcal twin`); the dataset has one sample per row (not with --count)")
      ->excludes(count);
  cmd->add_option("--profile", opt->job.profile,
                  "camera profile (camera_profile.yaml: tone curve, vignetting, blur, sharpening, Poisson-Gaussian noise, "
                  "background, the printed board's scale, bow and corner displacements; docs/rendered-datasets-and-images.md) "
                  "applied to every image");
  cmd->add_option("--seed", opt->seed, "seed of the configurations, the joint noise and the image noise")->capture_default_str();
  cmd->add_option("--joint-noise-deg", opt->joint_noise_deg, "control noise of the plant joints, 1 sigma [deg]")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 10.0));
  cmd->add_option("-o,--out", opt->job.out, "dataset folder (created; an unfinished one with the same inputs is resumed)")
      ->required();
  cmd->add_option("--shard", opt->shard,
                  "i/N: render only shard i (0 .. N-1) of N of the dataset, samples floor(i n / N) .. floor((i + 1) n / N) - 1 "
                  "with their global indices and image names, into a dataset folder of its own; "
                  "`orbcal merge-datasets` joins the shards");
  cmd->add_flag("--force", opt->job.force, "replace a dataset made from different inputs in --out");
  cmd->add_option("--png-compression", opt->job.png_compression,
                  "PNG compression level 0..9, or -1: OpenCV's fast path (zlib level 1, SUB filter); lossless at any level")
      ->capture_default_str()
      ->check(CLI::Range(-1, 9));
  cmd->callback([opt] {
    render::DatasetJob job = opt->job;
    job.robot = opt->as.robot;
    job.base_link = opt->as.base_link;
    job.tip_link = opt->as.tip_link;
    job.scene = opt->as.scene;
    job.configuration_seed = job.noise_seed = job.render_seed = opt->seed;
    job.joint_noise_sigma_rad = opt->joint_noise_deg * sim::kDegToRad;
    job.errors.angle_sigma_rad = opt->error_angle_sigma_deg * sim::kDegToRad;
    job.errors.length_sigma_m = opt->error_length_sigma_mm * 1e-3;
    if (!opt->shard.empty()) job.shard = sim::parseShardSpec(opt->shard, "--shard");
    setInterruptNote("the finished images are kept in " + job.out + ": rerun the same command to resume");
    std::unique_ptr<Progress> bar;  // made once the shard's size is known
    const render::DatasetRunReport r = render::renderDataset(job, [&](int done, int total) {
      if (!bar) bar = std::make_unique<Progress>("render", total);
      bar->update(done);
    });
    if (bar) bar->finish();
    for (const std::string& w : r.warnings) std::fprintf(stderr, "orbcal: warning: %s\n", w.c_str());
    if (job.shard) {
      std::printf("%s: shard %d/%d, samples %d..%d of %d; planned in %.1f s\n", job.out.c_str(), job.shard->first,
                  job.shard->second, r.first_sample, r.end_sample - 1, r.total_samples, r.plan_seconds);
    }
    std::printf("%s: %d images rendered, %d kept from an earlier run%s; MSAA %dx; %.1f s (%.0f ms per rendered image)\n",
                job.out.c_str(), r.rendered, r.skipped, r.resumed ? " (resumed)" : "", r.msaa_samples, r.render_seconds,
                r.rendered > 0 ? 1e3 * r.render_seconds / r.rendered : 0.0);
  });
}
}  // namespace

ORBCAL_COMMAND(30, addRenderCommand);

}  // namespace orbcal::tools
