// host_id's speed targets: CSV reading throughput, one cost evaluation
// (direct against normal-equation), and a whole fit of a 60 s, 1 kHz log
// with 10000 PSO iterations (target: well under one second on one core).
#include <benchmark/benchmark.h>

#include "host_id/delta_log.hpp"
#include "host_id/identify.hpp"
#include "host_id/regression.hpp"
#include "host_id/simulate.hpp"

namespace host_id {
namespace {

const DeltaLog& log60() {
  static const DeltaLog log = [] {
    SimulateOptions o;
    o.duration_s = 60.0;
    o.torque_noise = 0.015;
    o.encoder_bits = 17;
    DeltaLog l = simulate_log(o);
    l.name = "bench";
    return l;
  }();
  return log;
}

void BM_ReadDeltaLog60s(benchmark::State& state) {
  const std::string text = format_delta_log(log60());
  for (auto _ : state) {
    DeltaLog l = parse_delta_log(text, "bench.csv");
    benchmark::DoNotOptimize(l.t.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(text.size()));
  state.counters["file_MB"] = static_cast<double>(text.size()) / 1e6;
}
BENCHMARK(BM_ReadDeltaLog60s)->Unit(benchmark::kMillisecond);

const Regression& regression60() {
  static const Regression r = [] {
    const auto model = make_model({});
    const Samples s = prepare_samples(log60(), PrepareOptions{});
    return build_regression(*model, log60().geometry, log60().gravity_m_s2, s, "bench", 1);
  }();
  return r;
}

void BM_CostDirect(benchmark::State& state) {
  const Regression& r = regression60();
  const Eigen::VectorXd beta = Eigen::VectorXd::Constant(r.psi.cols(), 0.1);
  for (auto _ : state) benchmark::DoNotOptimize(direct_cost(r, beta));
  state.counters["rows"] = static_cast<double>(r.psi.rows());
}
BENCHMARK(BM_CostDirect)->Unit(benchmark::kMicrosecond);

void BM_CostQuadratic(benchmark::State& state) {
  const Regression& r = regression60();
  const QuadraticCost cost(r, Eigen::VectorXd::Zero(r.psi.cols()));
  const Eigen::VectorXd beta = Eigen::VectorXd::Constant(cost.parameters(), 0.1);
  for (auto _ : state) benchmark::DoNotOptimize(cost(beta));
}
BENCHMARK(BM_CostQuadratic)->Unit(benchmark::kNanosecond);

void BM_FitPso10000Iterations60s(benchmark::State& state) {
  FitOptions f;
  f.pso.iterations = 10000;
  f.pso.stall_iterations = 1000000;  // run all 10000 iterations, as the paper
  f.threads = 1;
  for (auto _ : state) {
    const FitResult r = fit_log(log60(), f);
    benchmark::DoNotOptimize(r.beta.data());
    state.counters["pso_iterations"] = static_cast<double>(r.pso->iterations);
  }
}
BENCHMARK(BM_FitPso10000Iterations60s)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_FitLeastSquares60s(benchmark::State& state) {
  FitOptions f;
  f.method = Method::kLeastSquares;
  f.threads = 1;
  for (auto _ : state) {
    const FitResult r = fit_log(log60(), f);
    benchmark::DoNotOptimize(r.beta.data());
  }
}
BENCHMARK(BM_FitLeastSquares60s)->Unit(benchmark::kMillisecond)->Iterations(3);

}  // namespace
}  // namespace host_id

BENCHMARK_MAIN();
