#include "delta/trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string_view>

#include "delta/splitmix.hpp"

namespace delta {

namespace {}

JointState FourierTrajectory::at(double t_s) const {
  JointState s;
  const double w = 2.0 * std::numbers::pi * base_frequency_hz;
  for (unsigned j = 0; j < 3; ++j) {
    double q = q0_rad[j], qd = 0.0, qdd = 0.0;
    for (std::size_t k = 0; k < a_rad_s[j].size(); ++k) {
      const double kw = static_cast<double>(k + 1) * w;
      const double sn = std::sin(kw * t_s), cs = std::cos(kw * t_s);
      const double a = a_rad_s[j][k], b = b_rad_s[j][k];
      q += a / kw * sn - b / kw * cs;
      qd += a * cs + b * sn;
      qdd += -a * kw * sn + b * kw * cs;
    }
    s.q_rad[j] = q;
    s.qd_rad_s[j] = qd;
    s.qdd_rad_s2[j] = qdd;
  }
  return s;
}

KinematicsStatus PickAndPlaceTrajectory::at(double t_s, JointState& out) const {
  const std::size_t n = points_m.size();
  const double cycle = segment_duration_s * static_cast<double>(n);
  double tc = std::fmod(t_s, cycle);
  if (tc < 0) tc += cycle;
  const auto seg = static_cast<std::size_t>(tc / segment_duration_s) % n;
  const double T = segment_duration_s;
  const double s = (tc - static_cast<double>(seg) * T) / T;
  // Minimum jerk: 10 s^3 - 15 s^4 + 6 s^5 and its derivatives.
  const double f = s * s * s * (10.0 - 15.0 * s + 6.0 * s * s);
  const double fd = 30.0 * s * s * (1.0 - s) * (1.0 - s) / T;
  const double fdd = 60.0 * s * (1.0 - s) * (1.0 - 2.0 * s) / (T * T);
  const Vec3<double>& A = points_m[seg];
  const Vec3<double>& B = points_m[(seg + 1) % n];
  const Vec3<double> d = B - A;
  const Vec3<double> p = A + d * f, pd = d * fd, pdd = d * fdd;
  const auto ik = inverse_kinematics(geometry, p);
  if (ik.status != KinematicsStatus::kOk) return ik.status;
  // qd = J^-1 pd; qdd = J^-1 (pdd - Jdot qd). J^-1 via the adjugate.
  const auto vk0 = velocity_kinematics(geometry, ik.theta_rad, JointVector<double>{}, p);
  if (vk0.status != KinematicsStatus::kOk) return vk0.status;
  const double det = vk0.jacobian.determinant();
  if (!(std::abs(det) > 0.0)) return KinematicsStatus::kSingular;
  const Mat3<double> inv_adj = vk0.jacobian.adjugate();
  const Vec3<double> qd = (inv_adj * pd) * (1.0 / det);
  const auto vk = velocity_kinematics(geometry, ik.theta_rad, {qd.x, qd.y, qd.z}, p);
  const Vec3<double> qdd = (inv_adj * (pdd - vk.jacobian_dot_qdot)) * (1.0 / det);
  out.q_rad = ik.theta_rad;
  out.qd_rad_s = {qd.x, qd.y, qd.z};
  out.qdd_rad_s2 = {qdd.x, qdd.y, qdd.z};
  return KinematicsStatus::kOk;
}

bool make_fourier_excitation(const Geometry& g, const Vec3<double>& centre_m, unsigned harmonics,
                             double base_frequency_hz, double max_amplitude_rad,
                             unsigned long long seed, FourierTrajectory& out) {
  const auto ik = inverse_kinematics(g, centre_m);
  if (ik.status != KinematicsStatus::kOk || harmonics == 0) return false;
  // SplitMix64 for coefficients in [-1, 1].
  SplitMix64 rng(seed);
  const auto uniform = [&rng]() { return rng.uniform() * 2.0 - 1.0; };
  const double w = 2.0 * std::numbers::pi * base_frequency_hz;
  FourierTrajectory base;
  base.base_frequency_hz = base_frequency_hz;
  base.q0_rad = ik.theta_rad;
  for (unsigned j = 0; j < 3; ++j) {
    base.a_rad_s[j].resize(harmonics);
    base.b_rad_s[j].resize(harmonics);
    double sum_amp = 0.0;
    for (unsigned k = 0; k < harmonics; ++k) {
      // Position amplitude ~ 1/k, so velocity amplitudes stay comparable.
      const double kw = static_cast<double>(k + 1) * w;
      base.a_rad_s[j][k] = uniform() * kw / static_cast<double>(k + 1);
      base.b_rad_s[j][k] = uniform() * kw / static_cast<double>(k + 1);
      sum_amp += std::hypot(base.a_rad_s[j][k], base.b_rad_s[j][k]) / kw;
    }
    // Scale so that the worst-case joint amplitude is max_amplitude_rad. The
    // mean of q over a period is q0, the centre's joint angles.
    const double s = max_amplitude_rad / sum_amp;
    for (unsigned k = 0; k < harmonics; ++k) {
      base.a_rad_s[j][k] *= s;
      base.b_rad_s[j][k] *= s;
    }
  }
  const WorkspaceLimits<double> limits;
  const double period = 1.0 / base_frequency_hz;
  for (double scale = 1.0; scale > 0.05; scale *= 0.85) {
    FourierTrajectory f = base;
    for (unsigned j = 0; j < 3; ++j) {
      for (unsigned k = 0; k < harmonics; ++k) {
        f.a_rad_s[j][k] *= scale;
        f.b_rad_s[j][k] *= scale;
      }
    }
    bool ok = true;
    for (int i = 0; i <= 2000 && ok; ++i) {
      const JointState s = f.at(period * i / 2000.0);
      const auto fk = forward_kinematics(g, s.q_rad);
      ok = fk.status == KinematicsStatus::kOk &&
           check_workspace(g, fk.position_m, limits).status == WorkspaceStatus::kInside;
    }
    if (ok) {
      out = f;
      return true;
    }
  }
  return false;
}

PickAndPlaceTrajectory default_pick_and_place(const Geometry& g) {
  PickAndPlaceTrajectory p;
  p.geometry = g;
  const double zl = -0.50, zh = -0.40;  // pick/place height and travel height
  p.points_m = {{-0.10, -0.05, zl}, {-0.10, -0.05, zh}, {0.10, 0.05, zh},
                {0.10, 0.05, zl},   {0.10, 0.05, zh},   {0.05, -0.10, zh},
                {0.05, -0.10, zl},  {0.05, -0.10, zh},  {-0.10, -0.05, zh}};
  p.segment_duration_s = 0.4;
  return p;
}

JointState BlendedFourierTrajectory::at(double t_s) const {
  JointState s = fourier.at(t_s);
  const double end = duration_s();
  const bool rising = t_s < blend_s;
  const bool falling = t_s > end - blend_s;
  if (!(rising || falling) || !(blend_s > 0.0)) return s;
  // w(x) = 10 x^3 - 15 x^4 + 6 x^5 over x = time into (or left of) the blend.
  const double x = std::clamp((rising ? t_s : end - t_s) / blend_s, 0.0, 1.0);
  const double w = x * x * x * (10.0 + x * (-15.0 + 6.0 * x));
  const double dw_dx = 30.0 * x * x * (1.0 - x) * (1.0 - x);
  const double ddw_dx2 = 60.0 * x * (1.0 - x) * (1.0 - 2.0 * x);
  const double dw = (rising ? dw_dx : -dw_dx) / blend_s;
  const double ddw = ddw_dx2 / (blend_s * blend_s);
  for (unsigned j = 0; j < 3; ++j) {
    const double d = s.q_rad[j] - fourier.q0_rad[j];
    const double dd = s.qd_rad_s[j];
    const double ddd = s.qdd_rad_s2[j];
    s.q_rad[j] = fourier.q0_rad[j] + w * d;
    s.qd_rad_s[j] = w * dd + dw * d;
    s.qdd_rad_s2[j] = w * ddd + 2.0 * dw * dd + ddw * d;
  }
  return s;
}

const FourierPreset* fourier_preset(const char* name) {
  static const FourierPreset kPresets[] = {
      {"path1", 1, 0.2, 5, 0.35, {0.0, 0.0, -0.42}, 2},
      {"path2", 2, 0.25, 5, 0.35, {0.0, 0.0, -0.42}, 2},
  };
  for (const FourierPreset& p : kPresets) {
    if (std::string_view(p.name) == name) return &p;
  }
  return nullptr;
}

}  // namespace delta
