#include "orbcal/workflow/experiment.hpp"

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <map>
#include <sstream>
#include <stdexcept>

#include "orbcal/workflow/calibrate.hpp"
#include "orbcal/workflow/report_html.hpp"
#include "orbcal/calib/observability.hpp"
#include "orbcal/calib/synthetic.hpp"
#include "orbcal/render/dataset_writer.hpp"
#include "orbcal/sim/config.hpp"
#include "orbcal/sim/configurations.hpp"
#include "orbcal/sim/fileio.hpp"
#include "orbcal/sim/identifiability.hpp"
#include "orbcal/sim/io.hpp"
#include "orbcal/sim/se3.hpp"
#include "orbcal/sim/truth.hpp"

namespace orbcal::workflow {

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

std::string fmt(const char* f, double v) { return formatNumber(f, v); }

void log(const ExperimentOptions& o, const std::string& line) {
  if (!o.quiet) std::cerr << line << "\n";
}

std::string quote(const std::string& s) { return shellQuote(s); }

/// The plant of a rendered dataset (its true_errors and errors.yaml).
sim::TrueArm trueArm(const sim::Dataset& d) {
  std::optional<sim::TrueArm> t = sim::datasetTrueArm(d);
  if (!t) throw sim::InputError(d.folder + "/manifest.yaml: true_errors: missing (not a rendered dataset)");
  return std::move(*t);
}

std::string inputsSection(const ExperimentOptions& o, const sim::Arm& arm, const sim::TrueArm& truth) {
  const Eigen::VectorXd y_true = truth.geometryErrors();
  std::ostringstream s;
  s << "## Inputs\n\n"
    << "- robot: `" << o.robot << "` (" << arm.name << ", " << arm.numJoints() << " joints, " << arm.numParams()
    << " parameter errors)\n"
    << "- scene: `" << o.scene << "`\n"
    << "- injected errors: `" << o.errors.name << "`; joint control noise " << fmt("%.4g", o.joint_noise_sigma_rad * sim::kRadToDeg)
    << " deg (1 sigma); seed " << o.seed << "\n"
    << "- program: orbcal " << ORBCAL_VERSION << "\n\n"
    << "Injected errors (per joint; angles in deg, lengths in mm):\n\n```\n"
    << sim::formatErrorSet(arm, y_true) << "```\n\n"
    << injectedEffects(truth, o.errors.name);
  return s.str();
}

std::string identificationObservability(const sim::Arm& nominal, const std::vector<calib::PoseObservation>& obs,
                                        double joint_noise_sigma_rad) {
  calib::PoseNoiseModel noise;
  noise.joint_noise_sigma_rad = joint_noise_sigma_rad;
  const calib::MarkerPoseModel model = calib::poseModel(nominal, obs, noise);
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.numParams());
  return calib::formatIndices(calib::observability(model, zero, calib::unidentifiableToFix(model, zero)));
}

std::string methodsLegend(const std::vector<calib::MethodSpec>& methods) {
  std::string s = "Methods:\n\n";
  for (const auto& m : methods) s += "- **" + m.name + "**: " + m.description + "\n";
  return s + "\n";
}

}  // namespace

std::string injectedEffects(const sim::TrueArm& truth, const std::string& source) {
  if (!truth.hasEffects()) return "";
  return "Injected effects (`" + source + "`; the floor is the true model with them):\n\n```\n" + sim::formatEffects(truth) +
         "```\n\n";
}

std::string drawFigure(const ExperimentOptions& o, const std::string& folder, const std::string& args,
                       const std::string& png, const std::string& caption) {
  return drawFigure(o.callbacks, o.plots, folder, args, png, caption);
}

std::vector<calib::MethodSpec> chosenMethods(const ExperimentOptions& o, std::vector<calib::MethodSpec> preset) {
  if (o.methods.empty()) return preset;
  const auto all = calib::comparisonMethods(o.joint_noise_sigma_rad);
  std::vector<calib::MethodSpec> chosen;
  for (const std::string& name : o.methods) chosen.push_back(calib::findMethod(all, name));
  return chosen;
}

std::pair<int, std::string> shellOutput(const std::string& command) {
  std::FILE* p = ::popen(command.c_str(), "r");
  if (!p) return {-1, {}};
  std::string out;
  char buf[4096];
  for (std::size_t n; (n = std::fread(buf, 1, sizeof buf, p)) > 0;) out.append(buf, n);
  return {::pclose(p), out};
}

std::pair<double, double> meanAndStd(const std::vector<double>& v) {
  double m = 0.0, s = 0.0;
  for (double x : v) m += x / static_cast<double>(v.size());
  for (double x : v) s += (x - m) * (x - m) / static_cast<double>(std::max<std::size_t>(1, v.size() - 1));
  return {m, std::sqrt(s)};
}

std::uint64_t fingerprint(const std::string& text) {
  std::uint64_t h = 0xcbf29ce484222325ULL;
  for (unsigned char c : text) h = (h ^ c) * 0x100000001b3ULL;
  return h;
}

MeasuredSet renderAndMeasure(const ExperimentOptions& o, const std::string& prefix, int count, std::uint64_t seed) {
  MeasuredSet m;
  // The folder is named by everything that determines the dataset, so runs with the same inputs
  // reuse (and resume) it, and runs with other inputs never collide with it. An error-set file counts
  // by its content, not its path (checked here before anything is rendered).
  const sim::TrueArm plant = sim::makeTrueArm(sim::loadArm(o.robotSource()), o.errors, "--errors");
  const std::string errors = plant.fromFile() ? "file:" + plant.file_text : o.errors.name;
  const std::string inputs = sim::readTextSource(o.robot) + '\0' + o.base_link + '\0' + o.tip_link + '\0' +
                             sim::readTextSource(o.scene) + '\0' + errors +
                             '\0' + std::to_string(o.errors.seed) + '\0' + formatNumber("%.17g", o.errors.angle_sigma_rad) +
                             '\0' + formatNumber("%.17g", o.errors.length_sigma_m) + '\0' +
                             formatNumber("%.17g", o.joint_noise_sigma_rad) + '\0' + std::to_string(count) + '\0' +
                             std::to_string(seed);
  char buf[160];
  std::snprintf(buf, sizeof buf, "%s-n%d-s%llu-%08llx", prefix.c_str(), count, static_cast<unsigned long long>(seed),
                static_cast<unsigned long long>(fingerprint(inputs) & 0xffffffffULL));
  const std::string name = buf;
  // What the progress bars say: "identification images", "validation images", "pool images".
  const std::string what = prefix.size() > 6 && prefix.compare(prefix.size() - 6, 6, "-ident") == 0   ? "identification images"
                           : prefix.size() > 6 && prefix.compare(prefix.size() - 6, 6, "-valid") == 0 ? "validation images"
                                                                                                       : "images (" + prefix + ")";
  render::DatasetJob job;
  job.robot = o.robot;
  job.base_link = o.base_link;
  job.tip_link = o.tip_link;
  job.scene = o.scene;
  job.errors = o.errors;
  job.count = count;
  job.configuration_seed = job.noise_seed = job.render_seed = seed;
  job.joint_noise_sigma_rad = o.joint_noise_sigma_rad;
  job.out = o.out + "/datasets/" + name;
  auto t0 = Clock::now();
  {
    Progress bar(o.callbacks.progress, o.quiet ? "" : "render " + what, o.quiet ? 0 : count);
    render::renderDataset(job, [&](int done, int) { bar.update(done); });
  }
  m.render_seconds = since(t0);
  {
    const sim::FolderLock lock(job.out, "orbcal experiment: measure");  // measurements.csv goes into the dataset
    m.dataset = sim::loadDataset(job.out);
    t0 = Clock::now();
    {
      Progress bar(o.callbacks.progress, o.quiet ? "" : "measure " + what, o.quiet ? 0 : count);
      m.measurements = vision::measureDataset(m.dataset, {}, [&](int done, int) { bar.update(done); });
    }
    m.measure_seconds = since(t0);
    sim::writeFileAtomic(job.out + "/measurements.csv", vision::formatMeasurementsCsv(m.measurements));
  }
  m.summary = vision::summarize(m.measurements);
  const sim::TrueArm truth = trueArm(m.dataset);
  for (std::size_t k = 0; k < m.dataset.samples.size(); ++k) {
    const sim::DatasetSample& s = m.dataset.samples[k];
    const sim::DatasetSample* previous = k > 0 ? &m.dataset.samples[k - 1] : nullptr;
    const int i = static_cast<int>(k);  // the plant's sample index, as the renderer numbered it
    m.plant.q_commanded.push_back(s.q_rad);
    m.plant.q_true.push_back(*s.q_true_rad);
    m.plant.base_T_flange_true.push_back(truth.flangePose(i, *s.q_true_rad, previous ? &*previous->q_true_rad : nullptr));
    m.plant.commanded_samples.push_back(truth.sample(i, s.q_rad, previous ? &previous->q_rad : nullptr));
    const vision::Measurement& meas = m.measurements[k];
    if (!meas.found()) continue;
    calib::PoseObservation obs;
    obs.q_rad = s.q_rad;
    obs.base_T_flange = meas.base_T_flange;
    obs.covariance = meas.covariance;
    m.observations.push_back(std::move(obs));
  }
  return m;
}

Table4Result runTable4(const ExperimentOptions& o, const std::string& folder_name) {
  const auto t0 = Clock::now();
  Table4Result r;
  sim::OutputFolder output(o.out + "/" + folder_name, "orbcal experiment");  // written as a whole
  const std::string& folder = output.path();
  r.identification = renderAndMeasure(o, folder_name + "-ident", o.identification, o.seed);
  r.validation = renderAndMeasure(o, folder_name + "-valid", o.validation, o.seed + kValidationSeedOffset);
  const sim::Arm& nominal = r.identification.dataset.arm;
  const sim::TrueArm truth = trueArm(r.identification.dataset);
  const Eigen::VectorXd y_true = truth.geometryErrors();
  if (r.identification.observations.empty()) {
    throw sim::InputError(o.out + "/datasets: no identification image gave a pose (" +
                          vision::summaryLine(r.identification.summary) + ")");
  }
  const auto methods = chosenMethods(o, calib::comparisonMethods(o.joint_noise_sigma_rad));
  log(o, "estimating with " + std::to_string(methods.size()) + " methods ...");
  r.comparison = calib::compareMethods(nominal, truth, r.identification.observations, r.validation.plant, methods);
  // Validation as a camera would see it: against the measured validation poses (found ones only).
  calib::PlantSamples measured;
  for (std::size_t k = 0; k < r.validation.measurements.size(); ++k) {
    if (!r.validation.measurements[k].found()) continue;
    measured.q_commanded.push_back(r.validation.plant.q_commanded[k]);
    measured.q_true.push_back(r.validation.plant.q_true[k]);
    measured.base_T_flange_true.push_back(r.validation.measurements[k].base_T_flange);
    measured.commanded_samples.push_back(r.validation.plant.commanded_samples[k]);
  }
  r.measured_comparison = calib::revalidate(r.comparison, nominal, truth, measured);

  sim::writeFileAtomic(folder + "/validation_errors.csv", calib::formatValidationErrorsCsv(r.comparison));
  sim::writeFileAtomic(folder + "/validation_errors_measured.csv", calib::formatValidationErrorsCsv(r.measured_comparison));
  sim::writeFileAtomic(folder + "/estimates.csv", calib::formatEstimatesCsv(nominal, r.comparison, &y_true));
  sim::writeFileAtomic(folder + "/summary.csv", calib::formatComparisonSummaryCsv(r.comparison));

  std::vector<Eigen::VectorXd> ident_configs = r.identification.plant.q_commanded;
  std::ostringstream md;
  md << "# Table 4 from rendered images\n\n"
     << "Wang et al. 2023's Table 4 experiment run through the whole image pipeline: the arm with injected errors "
     << "moves the camera, the board is rendered (OSMesa), corners detected, the board pose solved (PnP) and "
     << "turned into the measured flange pose with its covariance, then every estimator identifies the "
     << nominal.numParams() << " errors. Validation: " << o.validation
     << " further configurations, against the true flange poses (the paper's setting) and against the poses "
     << "the camera measures.\n\n"
     << inputsSection(o, nominal, truth)
     << "## Images\n\n"
     << "- identification: " << vision::formatSummary(r.identification.summary) << " (render "
     << fmt("%.1f", r.identification.render_seconds) << " s, measure " << fmt("%.1f", r.identification.measure_seconds)
     << " s)\n"
     << "- validation: " << vision::formatSummary(r.validation.summary) << " (render "
     << fmt("%.1f", r.validation.render_seconds) << " s, measure " << fmt("%.1f", r.validation.measure_seconds)
     << " s)\n\n"
     << "## Identifiability of the identification set\n\n```\n"
     << sim::formatIdentifiability(sim::analyzeIdentifiability(nominal, ident_configs)) << "```\n\n"
     << "Observability indices of the identification images (Borm & Menq 1991 O1 to Sun & Hollerbach 2008 O5; R = the "
        "vision covariance plus the control noise, columns in typical magnitudes, unidentifiable parameters left out; "
        "larger is better; `orbcal experiment --preset selection` measures what choosing them by an index gains): "
     << identificationObservability(nominal, r.identification.observations, o.joint_noise_sigma_rad) << ".\n\n"
     << "## Validation against the true poses\n\n"
     << "Position in mm, orientation (absolute X/Y/Z components of the rotation error, base frame) in deg; "
     << "improvement = (initial - calibrated) / initial. `floor` = the true parameters: the error the control noise "
     << "alone leaves, which no estimator can beat.\n\n"
     << calib::formatComparisonSummary(r.comparison) << "\n"
     << calib::formatMethodsTable(nominal, r.comparison, y_true) << "\n"
     << "### Identified against injected\n\n"
     << calib::formatEstimatesAgainstTruth(nominal, r.comparison, y_true, {"LSE (weighted)", "EKF", "LM"})
     << "\n(+- 1 sigma; held: unidentifiable, kept at zero; suspicious estimates in bold; every method's in `estimates.csv`.)\n\n"
     << "<details><summary>Per method, Wang et al. 2023's Table 4 layout</summary>\n\n"
     << calib::formatComparisonDetail(r.comparison) << "</details>\n\n"
     << drawFigure(o, folder, "boxplot " + quote(folder + "/validation_errors.csv"), "validation_boxplot.png",
                   "validation errors")
     << "\n## Validation against the poses the camera measured\n\n"
     << "What a user without ground truth sees: the same estimates, against the measured validation poses "
     << "(their measurement noise adds to every column).\n\n"
     << calib::formatComparisonSummary(r.measured_comparison) << "\n"
     << methodsLegend(methods)
     << "Files: `summary.csv` (per method: average and largest error, x floor), `validation_errors.csv`, "
        "`validation_errors_measured.csv`, `estimates.csv` (per method and "
     << "parameter: estimate, 1-sigma, truth, held), datasets under `" << o.out << "/datasets/`.\n\n"
     << "## Headline\n\n```\n" << table4Headline(r) << "```\n";
  writeReport(folder, md.str());
  output.commit();
  r.report_path = output.finalPath() + "/report.md";
  r.seconds = since(t0);
  return r;
}

std::string table4Headline(const Table4Result& r) {
  const calib::Comparison& c = r.comparison;
  const calib::MethodOutcome* ekf = calib::bestOfKind(c, calib::MethodSpec::Kind::kEkf);
  const calib::MethodOutcome* lse = calib::bestOfKind(c, calib::MethodSpec::Kind::kLse);
  const calib::MethodOutcome* lm = calib::bestOfKind(c, calib::MethodSpec::Kind::kLm);
  std::ostringstream s;
  s << "identification images used: " << r.identification.observations.size() << " of "
    << r.identification.measurements.size() << "; validation configurations: " << r.validation.plant.q_commanded.size()
    << "\n";
  s << "average validation position error: initial " << fmt("%.3f", c.initial.position_avg_m * 1e3)
    << " mm, floor (control noise alone) " << fmt("%.3f", c.floor.position_avg_m * 1e3) << " mm\n";
  for (const calib::MethodOutcome* m : {ekf, lse, lm}) {
    if (!m) continue;
    const calib::ErrorSummary& a = m->summary;
    s << "best " << m->method.name << ": " << fmt("%.3f", a.position_avg_m * 1e3) << " mm ("
      << fmt("%.2f", a.position_avg_m / c.floor.position_avg_m) << " x floor); improvement position "
      << fmt("%.1f", 100 * calib::improvement(c.initial.position_avg_m, a.position_avg_m)) << "%, orientation X/Y/Z "
      << fmt("%.1f", 100 * calib::improvement(c.initial.orientation_avg_rad.x(), a.orientation_avg_rad.x())) << "/"
      << fmt("%.1f", 100 * calib::improvement(c.initial.orientation_avg_rad.y(), a.orientation_avg_rad.y())) << "/"
      << fmt("%.1f", 100 * calib::improvement(c.initial.orientation_avg_rad.z(), a.orientation_avg_rad.z())) << "%\n";
  }
  s << "report: " << r.report_path << "\n";
  return s.str();
}

}  // namespace orbcal::workflow
