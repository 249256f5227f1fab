// See campaign_analysis.h.
#include "analysis/campaign_analysis.h"

#include <atomic>
#include <filesystem>
#include <mutex>
#include <thread>

#include "analysis/run_pass.h"

namespace granary::analysis {

std::vector<Metric> CampaignAnalysis::RunMetrics(std::size_t a, std::size_t run) const {
  if (a >= results.size() || run >= results[a].runs.size() || results[a].runs[run].is_null()) return {};
  return setup->analyses[a]->RunMetrics(results[a].runs[run]);
}

std::vector<PointMetric> CampaignAnalysis::AllPointMetrics(std::size_t p) const {
  std::vector<PointMetric> out;
  for (const PointMetricTable& t : point_metrics)
    if (p < t.size()) out.insert(out.end(), t[p].begin(), t[p].end());
  return out;
}

std::unique_ptr<CampaignAnalysis> AnalyseCampaign(const CampaignInfo& info, const std::vector<RunRecord>& runs,
                                                  const AnalysisSetup& setup, const CampaignAnalysisOptions& options) {
  auto out = std::make_unique<CampaignAnalysis>();
  out->setup = &setup;
  const std::vector<const Analysis*> analyses = setup.List();
  std::vector<const RunRecord*> done;
  for (const RunRecord& r : runs)
    if (r.state == "done" && std::filesystem::exists(r.run_dir)) done.push_back(&r);  // else lost

  // One pass per finished run. Many runs: one run per thread; few: each pass reads ahead on a
  // second thread. Either way every result is the same bits.
  const int jobs =
      options.jobs > 0 ? options.jobs : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  const int workers = std::max(1, std::min<int>(jobs, static_cast<int>(done.size())));
  RunPassOptions pass_options;
  pass_options.threads = static_cast<int>(done.size()) >= jobs ? 1 : jobs;
  pass_options.read_cache = options.read_cache;
  pass_options.write_cache = options.write_cache;
  std::vector<RunPassResult> passes(done.size());
  std::map<std::string, std::string> unreadable;
  RunChecks checks;
  std::mutex mutex;
  std::atomic<std::size_t> next{0};
  int finished = 0;
  auto work = [&] {
    for (std::size_t i = next++; i < done.size(); i = next++) {
      std::string error;
      rundir::Verification check;
      try {
        // Before any cached result is used: a run damaged after it was analysed is not
        // analysed again, and its cached results are not used (rundir/manifest.h).
        check = rundir::VerifyRun(done[i]->run_dir, {rundir::VerifyLevel::kCached, options.write_cache});
        if (check.integrity != rundir::Integrity::kDamaged)
          passes[i] = AnalyseRun(done[i]->run_dir, analyses, setup.pass, pass_options);
      } catch (const std::exception& e) {
        error = e.what();
      }
      std::lock_guard<std::mutex> lock(mutex);
      if (!error.empty()) unreadable[done[i]->run_id] = error;
      checks[done[i]->run_id] = std::move(check);
      ++finished;
      if (options.progress) options.progress(finished, static_cast<int>(done.size()));
    }
  };
  if (workers <= 1) {
    work();
  } else {
    std::vector<std::thread> threads;
    for (int t = 0; t < workers; ++t) threads.emplace_back(work);
    for (std::thread& t : threads) t.join();
  }

  out->view = MakeCampaignView(info, runs, unreadable, checks);
  std::map<const RunRecord*, const RunPassResult*> by_record;
  for (std::size_t i = 0; i < done.size(); ++i) by_record[done[i]] = &passes[i];
  out->results.assign(analyses.size(), AnalysisResults{&out->view, {}, setup.pass});
  for (std::size_t a = 0; a < analyses.size(); ++a) out->results[a].runs.assign(out->view.used.size(), nullptr);
  for (std::size_t u = 0; u < out->view.used.size(); ++u) {
    const auto it = by_record.find(out->view.used[u].record);
    if (it == by_record.end()) continue;
    out->results_from_cache += it->second->from_cache;
    out->results_computed += static_cast<int>(it->second->results.size()) - it->second->from_cache;
    for (std::size_t a = 0; a < analyses.size(); ++a) out->results[a].runs[u] = it->second->results[a];
  }
  for (std::size_t a = 0; a < analyses.size(); ++a) {
    PointMetricTable table;
    for (std::size_t p = 0; p < out->view.points.size(); ++p)
      table.push_back(analyses[a]->PointMetrics(out->results[a], p));
    out->point_metrics.push_back(std::move(table));
  }
  return out;
}

}  // namespace granary::analysis
