// The simulated robot's cost: one 500 Hz control cycle of the emulator on
// each plant, in the emulator's sub-steps (lumped: 8 of 0.25 ms; MuJoCo: 2
// of 1 ms, and the plant's own 4 of 0.5 ms), and `host_id simulate --plant
// mujoco` throughput. Ratios in one run: the multibody
// plant against the lumped one it replaced as the emulator's default.
#include <benchmark/benchmark.h>

#include <cmath>
#include <memory>

#include "delta/mujoco_plant.hpp"
#include "delta/plant.hpp"
#include "host_id/simulate.hpp"

namespace {

// A swing about the pose where the holding torques balance gravity.
template <class MakePlant>
void run_cycles(benchmark::State& state, int substeps, MakePlant make) {
  const delta::Joint3 q0{0.3, 0.45, 0.35};
  delta::MujocoPlant reference(delta::default_robot_description(), q0);
  const delta::Joint3 hold = reference.inverse_dynamics(delta::JointState{q0, {}, {}});
  auto plant = make(q0);
  double t = 0.0;
  for (auto _ : state) {
    const double h = 2e-3 / substeps;
    for (int sub = 0; sub < substeps; ++sub) {
      const double push = 0.05 * std::sin(6.0 * t);
      const delta::Joint3 tau{hold[0] + push, hold[1] - push, hold[2] + 0.5 * push};
      if (plant->step(tau, h) != delta::PlantStatus::kOk) {
        state.SkipWithError(plant->fault().c_str());
        return;
      }
      t += h;
    }
  }
  state.counters["cycles_per_s"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}

void BM_PlantCycle_Lumped(benchmark::State& state) {
  run_cycles(state, 8, [](const delta::Joint3& q0) {
    return std::make_unique<delta::LumpedPlant>(delta::kDefaultGeometry,
                                                delta::default_lumped_parameters(), q0);
  });
}
BENCHMARK(BM_PlantCycle_Lumped)->Unit(benchmark::kMicrosecond);

// The plant's own default (host_id simulate): 4 steps of 0.5 ms.
void BM_PlantCycle_MujocoEuler(benchmark::State& state) {
  run_cycles(state, 4, [](const delta::Joint3& q0) {
    return std::make_unique<delta::MujocoPlant>(delta::default_robot_description(), q0);
  });
}
BENCHMARK(BM_PlantCycle_MujocoEuler)->Unit(benchmark::kMicrosecond);

// The emulator's: 2 steps of kMujocoCoarsestStep_s (1 ms).
void BM_PlantCycle_MujocoEulerEmulator(benchmark::State& state) {
  run_cycles(state, 2, [](const delta::Joint3& q0) {
    return std::make_unique<delta::MujocoPlant>(
        delta::default_robot_description(), q0,
        delta::MujocoSettings{delta::MujocoIntegrator::kEuler, delta::kMujocoCoarsestStep_s});
  });
}
BENCHMARK(BM_PlantCycle_MujocoEulerEmulator)->Unit(benchmark::kMicrosecond);

// The first choice, before the HIL VM's cost: RK4 at 1/8 ms.
void BM_PlantCycle_MujocoRk4EighthMs(benchmark::State& state) {
  run_cycles(state, 8, [](const delta::Joint3& q0) {
    return std::make_unique<delta::MujocoPlant>(
        delta::default_robot_description(), q0,
        delta::MujocoSettings{delta::MujocoIntegrator::kRk4, 1.25e-4});
  });
}
BENCHMARK(BM_PlantCycle_MujocoRk4EighthMs)->Unit(benchmark::kMicrosecond);

// Simulated seconds per wall second of a 5 s, 1 kHz multibody log.
void BM_SimulateMujoco5s(benchmark::State& state) {
  host_id::SimulateOptions o;
  o.plant = host_id::SimulatedPlant::kMujoco;
  o.duration_s = 5.0;
  for (auto _ : state) benchmark::DoNotOptimize(host_id::simulate_log(o));
  state.counters["simulated_s_per_s"] = benchmark::Counter(
      5.0 * static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
}
BENCHMARK(BM_SimulateMujoco5s)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
