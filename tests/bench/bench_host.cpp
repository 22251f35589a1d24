// host_id's speed targets on a 60 s, 1 kHz log (7.9 MB): each stage of a
// fit (read, parse, preprocess, regressor, solve, covariance, PSO), one cost
// evaluation (direct against O(p^2)), and whole fits. tests/bench/fit_speed.py
// turns the stages into the ratios of docs/dev/performance.md.
#include <benchmark/benchmark.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>

#include "delta/read_file.hpp"
#include "host_id/delta_log.hpp"
#include "host_id/design.hpp"
#include "host_id/identify.hpp"
#include "host_id/least_squares.hpp"
#include "host_id/parallel.hpp"
#include "host_id/preprocess.hpp"
#include "host_id/pso.hpp"
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

// A file removed when the program ends. (An atexit handler registered
// while the path's static was being built ran after that static was
// destroyed, so the file stayed behind in /tmp.)
struct TemporaryFile {
  std::string path;
  ~TemporaryFile() { std::remove(path.c_str()); }
};

// The log as a file (in the page cache after its first read).
const std::string& log60_path() {
  static const TemporaryFile file = [] {
    const std::string p = "/tmp/bench_host_log60_" + std::to_string(::getpid()) + ".csv";
    std::ofstream(p, std::ios::binary) << format_delta_log(log60());
    return TemporaryFile{p};
  }();
  return file.path;
}

void BM_Stage1_Read60s(benchmark::State& state) {
  std::size_t bytes = 0;
  for (auto _ : state) {
    const delta::FileBytes text = delta::read_file_bytes(log60_path());
    bytes = text.view().size();
    benchmark::DoNotOptimize(text.view().data());
  }
  state.SetBytesProcessed(state.iterations() * static_cast<int64_t>(bytes));
}
BENCHMARK(BM_Stage1_Read60s)->Unit(benchmark::kMillisecond);

void BM_Stage2_Parse60s(benchmark::State& state) {
  const std::string text = format_delta_log(log60());
  for (auto _ : state) {
    DeltaLog l = parse_delta_log(text, "bench.csv");
    benchmark::DoNotOptimize(l.t.data());
  }
  state.SetBytesProcessed(static_cast<int64_t>(state.iterations()) *
                          static_cast<int64_t>(text.size()));
  state.counters["file_MB"] = static_cast<double>(text.size()) / 1e6;
}
BENCHMARK(BM_Stage2_Parse60s)->Unit(benchmark::kMillisecond);

// Both, as a fit does: the reference of the speed bars.
void BM_ReadAndParse60s(benchmark::State& state) {
  for (auto _ : state) {
    DeltaLog l = read_delta_log(log60_path());
    benchmark::DoNotOptimize(l.t.data());
  }
}
BENCHMARK(BM_ReadAndParse60s)->Unit(benchmark::kMillisecond);

// Preprocessing: filter q, differentiate, the regressor (kinematics per
// sample), its columns and tau filtered, trimmed; on one thread.
void BM_Stage3_PreprocessWithRegressor60s(benchmark::State& state) {
  const auto model = make_model({});
  for (auto _ : state) {
    const Preprocessed p = preprocess(*model, log60(), PrepareOptions{}, 1);
    benchmark::DoNotOptimize(p.regression.psi.data());
  }
}
BENCHMARK(BM_Stage3_PreprocessWithRegressor60s)->Unit(benchmark::kMillisecond);

const Regression& regression60() {
  static const Regression r = [] {
    const auto model = make_model({});
    return preprocess(*model, log60(), PrepareOptions{}, 1).regression;
  }();
  return r;
}

// Least squares without (lags 0: the white-noise formula, nearly free) and
// with the correlated-residual covariance of a fit (100 lags at 1 kHz).
void BM_Stage4_Solve60s(benchmark::State& state) {
  const auto model = make_model({});
  for (auto _ : state) {
    const auto ls =
        solve_least_squares(regression60(), *model, LsSolver::kQr, LsWeights::kNone, "bench", 0);
    benchmark::DoNotOptimize(ls.beta.data());
  }
}
BENCHMARK(BM_Stage4_Solve60s)->Unit(benchmark::kMillisecond);

void BM_Stage5_SolveWithCovariance60s(benchmark::State& state) {
  const auto model = make_model({});
  const std::size_t lags = correlation_lags_for(1000.0, kDefaultCutoffHz);
  for (auto _ : state) {
    const auto ls =
        solve_least_squares(regression60(), *model, LsSolver::kQr, LsWeights::kNone, "bench", lags);
    benchmark::DoNotOptimize(ls.beta.data());
  }
}
BENCHMARK(BM_Stage5_SolveWithCovariance60s)->Unit(benchmark::kMillisecond);

// PSO with the default options (stall stop) on the O(p^2) cost.
void BM_Stage6_Pso60s(benchmark::State& state) {
  const Regression& r = regression60();
  const auto model = make_model({});
  const auto ls = solve_least_squares(r, *model, LsSolver::kQr, LsWeights::kNone, "bench", 0);
  const Eigen::VectorXd upper =
      10.0 * ls.beta.cwiseAbs() + Eigen::VectorXd::Constant(ls.beta.size(), 1e-3);
  const Eigen::VectorXd lower = -upper;
  const QuadraticCost cost = QuadraticCost(r, ls.beta).over_box(lower, upper);  // as the fit does
  for (auto _ : state) {
    const PsoResult p = run_pso_normalized([&cost](const double* u) { return cost.at(u); }, lower,
                                           upper, PsoOptions{});
    benchmark::DoNotOptimize(p.best.data());
    state.counters["iterations"] = static_cast<double>(p.iterations);
  }
}
BENCHMARK(BM_Stage6_Pso60s)->Unit(benchmark::kMillisecond);

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

// host_id design's search on the default robot: 5 harmonics, default
// options, one core (the bar: at most 30 s).
void BM_Design5Harmonics(benchmark::State& state) {
  const delta::RobotDescription robot = delta::default_robot_description();
  const DesignOptions o = default_design_options();
  for (auto _ : state) benchmark::DoNotOptimize(design_excitation(o, robot).quality);
}
BENCHMARK(BM_Design5Harmonics)->Unit(benchmark::kSecond)->Iterations(3);

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

// What `host_id fit LOG.csv [--method ls]` does before it prints: read,
// parse and fit (default options, stall stop for PSO), on one thread.
void BM_FitFromFileLeastSquares60s(benchmark::State& state) {
  FitOptions f;
  f.method = Method::kLeastSquares;
  f.threads = 1;
  for (auto _ : state) {
    const FitResult r = fit_log(read_delta_log(log60_path()), f);
    benchmark::DoNotOptimize(r.beta.data());
  }
}
BENCHMARK(BM_FitFromFileLeastSquares60s)->Unit(benchmark::kMillisecond);

void BM_FitFromFilePso60s(benchmark::State& state) {
  FitOptions f;
  f.threads = 1;
  for (auto _ : state) {
    const FitResult r = fit_log(read_delta_log(log60_path()), f);
    benchmark::DoNotOptimize(r.beta.data());
  }
}
BENCHMARK(BM_FitFromFilePso60s)->Unit(benchmark::kMillisecond);

// run_tasks with two workers on two tasks of 1 ms of CPU time each: the
// wall time is 1 ms where both run at once, 2 ms where one waits behind
// the other (as a new thread did behind the thread that made it).
void BM_RunTasksTwoTasksOf1ms(benchmark::State& state) {
  const auto thread_cpu_ns = [] {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) * 1e9 + static_cast<double>(t.tv_nsec);
  };
  for (auto _ : state) {
    run_tasks(2, 2, [&](std::size_t, std::size_t) {
      const double start = thread_cpu_ns();
      double x = 0.0;
      while (thread_cpu_ns() - start < 1e6) benchmark::DoNotOptimize(x += 1.0);
    });
  }
}
BENCHMARK(BM_RunTasksTwoTasksOf1ms)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace host_id

BENCHMARK_MAIN();
