// The C++ baseline of issue 33 item 1: a 6-D impedance loop on the desired frame (9.30), (9.35)
// against an elastic table, written directly against Pinocchio, no abstractions, no checks.
//
// The same closed loop as forcecontrol's Python engine runs for a SpatialImpedanceController
// (XYZ Euler error, null-space posture, variable damped least squares, u = B y + n + J^T h)
// with a Table environment and an ideal sensor: per sample one computeAllTerms for the law, then
// RK4 with nsub sub-steps and the torque held, each stage forwardKinematics + the frame's velocity
// for the wrench, the frame Jacobian while in contact, and ABA on u - F qd - J^T h.
// A constant desired frame (a setpoint): the reference's velocity and acceleration are zero.
//
// The model is built here with Pinocchio's API from the parameters of the model the library loaded
// from its URDF (the pin wheels ship no urdfdom headers): per joint its type (0 revolute, 1
// prismatic) and axis, placement in the parent joint, body inertia, armature and damping; the
// controlled frame's parent joint and placement; gravity.
//
// Usage: panda_impedance <params.txt> <trajectory_out.txt>
// params.txt: whitespace-separated numbers, in this order:
//   n  per joint: kind axis[3] R[9] p[3] mass com[3] I[9] armature damping
//   frame: parent_joint R[9] p[3]  gravity[3]
//   q0[n]  o_d[3] phi_d[3]  Md_inv[36] K_D[36] K_P[36]  posture[n] k_n d_n has_posture thr lmax
//   table point[3] normal[3] k c  duration Ts nsub repeats
// Prints: "us_per_step <median> <min>" over the repeats; writes q per sample (one row each).
// Build: benchmarks/cpp/build.sh (g++ with the pin wheels' headers and libraries).

#include <pinocchio/multibody.hpp>
#include <pinocchio/algorithm/model.hpp>
#include <pinocchio/algorithm/compute-all-terms.hpp>
#include <pinocchio/algorithm/kinematics.hpp>
#include <pinocchio/algorithm/frames.hpp>
#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/jacobian.hpp>
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

namespace pin = pinocchio;
using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;
using M6 = Eigen::Matrix<double, 6, 6>;
using V6 = Eigen::Matrix<double, 6, 1>;
using M3 = Eigen::Matrix3d;
using V3 = Eigen::Vector3d;

static M3 rot_xyz(const V3& p) {
  double c1 = std::cos(p[0]), s1 = std::sin(p[0]), c2 = std::cos(p[1]), s2 = std::sin(p[1]), c3 = std::cos(p[2]), s3 = std::sin(p[2]);
  M3 R;
  R << c2 * c3, -c2 * s3, s2,
       c1 * s3 + s1 * s2 * c3, c1 * c3 - s1 * s2 * s3, -s1 * c2,
       s1 * s3 - c1 * s2 * c3, s1 * c3 + c1 * s2 * s3, c1 * c2;
  return R;
}

int main(int argc, char** argv) {
  if (argc < 3) {
    std::cerr << "usage: panda_impedance <params.txt> <trajectory_out.txt>\n";
    return 2;
  }
  std::ifstream in(argv[1]);
  int n;
  in >> n;
  auto read = [&](int k) { Vec v(k); for (int i = 0; i < k; ++i) in >> v[i]; return v; };
  auto read_se3 = [&]() {
    Vec r = read(9), p = read(3);
    return pin::SE3(Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(r.data()), V3(p));
  };
  pin::Model model;
  Vec armature(n), damping(n);
  pin::JointIndex parent = 0;
  for (int i = 0; i < n; ++i) {
    int kind;
    in >> kind;
    V3 ax = read(3);
    pin::SE3 placement = read_se3();
    double mass;
    in >> mass;
    V3 com = read(3);
    Vec I9 = read(9);
    in >> armature[i] >> damping[i];
    const std::string name = "j" + std::to_string(i);
    int axis_id = ax == V3::UnitX() ? 0 : ax == V3::UnitY() ? 1 : ax == V3::UnitZ() ? 2 : 3;
    if (kind == 0) {
      if (axis_id == 0) parent = model.addJoint(parent, pin::JointModelRX(), placement, name);
      else if (axis_id == 1) parent = model.addJoint(parent, pin::JointModelRY(), placement, name);
      else if (axis_id == 2) parent = model.addJoint(parent, pin::JointModelRZ(), placement, name);
      else parent = model.addJoint(parent, pin::JointModelRevoluteUnaligned(ax), placement, name);
    } else {
      if (axis_id == 0) parent = model.addJoint(parent, pin::JointModelPX(), placement, name);
      else if (axis_id == 1) parent = model.addJoint(parent, pin::JointModelPY(), placement, name);
      else if (axis_id == 2) parent = model.addJoint(parent, pin::JointModelPZ(), placement, name);
      else parent = model.addJoint(parent, pin::JointModelPrismaticUnaligned(ax), placement, name);
    }
    model.appendBodyToJoint(parent, pin::Inertia(mass, com, Eigen::Map<Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(I9.data())),
                            pin::SE3::Identity());
  }
  int frame_joint;
  in >> frame_joint;
  pin::SE3 frame_placement = read_se3();
  const pin::FrameIndex fid = model.addFrame(pin::Frame("tool", frame_joint, 0, frame_placement, pin::OP_FRAME));
  model.gravity.linear(read(3));
  model.armature = armature;
  model.damping = damping;
  pin::Data data(model);
  const auto LWA = pin::LOCAL_WORLD_ALIGNED;

  Vec q0 = read(n);
  V3 o_d = read(3), phi_d = read(3);
  Vec t36 = read(36); M6 Md_inv = Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(t36.data());
  t36 = read(36); M6 K_D = Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(t36.data());
  t36 = read(36); M6 K_P = Eigen::Map<Eigen::Matrix<double, 6, 6, Eigen::RowMajor>>(t36.data());
  Vec posture = read(n);
  double k_n, d_n, has_posture, thr, lmax;
  in >> k_n >> d_n >> has_posture >> thr >> lmax;
  V3 tp = read(3), nrm = read(3);
  double k_env, c_env, duration, Ts;
  int nsub, repeats;
  in >> k_env >> c_env >> duration >> Ts >> nsub >> repeats;
  if (!in) { std::cerr << "params file is short\n"; return 2; }

  const M3 RdT = rot_xyz(phi_d).transpose();
  const Vec F = model.damping;
  const int N = static_cast<int>(std::lround(duration / Ts));
  std::vector<Vec> log_q(N + 1);

  // the table's wrench at (o_e, ȯ_e): force only, about o_e
  auto table = [&](const V3& o, const V3& v) {
    V6 h = V6::Zero();
    double delta = nrm.dot(tp - o);
    if (delta <= 0.0) return h;
    double mag = k_env * delta - c_env * nrm.dot(v);
    if (mag > 0.0) h.head<3>() = -mag * nrm;
    return h;
  };
  Mat Jst(6, n);
  auto accel = [&](const Vec& q, const Vec& qd, const Vec& u) {
    pin::forwardKinematics(model, data, q, qd);
    pin::updateFramePlacement(model, data, fid);
    V6 tw = pin::getFrameVelocity(model, data, fid, LWA).toVector();
    V6 h = table(data.oMf[fid].translation(), tw.head<3>());
    Vec tau = u - F.cwiseProduct(qd);
    if (!h.isZero(0.0)) {
      Jst.setZero();
      pin::computeFrameJacobian(model, data, q, fid, LWA, Jst);
      tau -= Jst.transpose() * h;
    }
    return Vec(pin::aba(model, data, q, qd, tau));
  };

  Mat J(6, n);
  std::vector<double> times;
  for (int rep = 0; rep < repeats; ++rep) {
    Vec q = q0, qd = Vec::Zero(n);
    auto t0 = std::chrono::steady_clock::now();
    const double dt = Ts / nsub;
    for (int k = 0; k <= N; ++k) {
      // the law (one computeAllTerms)
      pin::computeAllTerms(model, data, q, qd);
      pin::updateFramePlacement(model, data, fid);
      const pin::SE3& M = data.oMf[fid];
      J.setZero();
      pin::getFrameJacobian(model, data, fid, LWA, J);
      V6 Jdq = pin::getFrameClassicalAcceleration(model, data, fid, LWA).toVector();
      Mat B = data.M;
      B.triangularView<Eigen::StrictlyLower>() = B.transpose().triangularView<Eigen::StrictlyLower>();
      Vec nle = data.nle + F.cwiseProduct(qd);
      V6 v = J * qd;
      V6 h = table(M.translation(), v.head<3>());
      M3 R_de = RdT * M.rotation();
      double c2 = std::hypot(R_de(0, 0), R_de(0, 1));
      double s2 = std::min(1.0, std::max(-1.0, R_de(0, 2)));
      double p1 = std::atan2(-R_de(1, 2), R_de(2, 2)), p2 = std::atan2(s2, c2), p3 = std::atan2(-R_de(0, 1), R_de(0, 0));
      double cc1 = std::cos(p1), ss1 = std::sin(p1), cc2 = std::cos(p2), ss2 = std::sin(p2);
      M3 Tinv;
      Tinv << 1.0, ss1 * ss2 / cc2, -cc1 * ss2 / cc2, 0.0, cc1, ss1, 0.0, -ss1 / cc2, cc1 / cc2;
      V3 phid = Tinv * (RdT * v.tail<3>());
      double d1 = phid[0], d2 = phid[1];
      M3 Tdot;
      Tdot << 0.0, 0.0, cc2 * d2, 0.0, -ss1 * d1, -cc1 * cc2 * d1 + ss1 * ss2 * d2, 0.0, cc1 * d1, -ss1 * cc2 * d1 - cc1 * ss2 * d2;
      V6 x, xd, c;
      x.head<3>() = -(RdT * (M.translation() - o_d));
      x.tail<3>() << -p1, -p2, -p3;
      xd.head<3>() = -(RdT * v.head<3>());
      xd.tail<3>() = -phid;
      Eigen::Matrix<double, 6, Eigen::Dynamic> JAd(6, n);
      JAd.topRows<3>() = RdT * J.topRows<3>();
      JAd.bottomRows<3>() = Tinv * (RdT * J.bottomRows<3>());
      c.head<3>() = -(RdT * Jdq.head<3>());
      c.tail<3>() = -(Tinv * (RdT * Jdq.tail<3>() - Tdot * phid));
      V6 h_d;
      h_d.head<3>() = RdT * h.head<3>();
      h_d.tail<3>() = RdT * h.tail<3>();
      V6 r = c + Md_inv * (K_D * xd + K_P * x - h_d);
      M6 JJt = JAd * JAd.transpose();
      if (lmax > 0.0) {
        double smin2 = Eigen::SelfAdjointEigenSolver<M6>(JJt, Eigen::EigenvaluesOnly).eigenvalues()[0];
        if (smin2 < thr * thr) JJt.diagonal().array() += lmax * lmax * (1.0 - std::max(smin2, 0.0) / (thr * thr));
      }
      Vec y;
      if (has_posture != 0.0) {
        Vec y0 = k_n * (posture - q) - d_n * qd;
        y = y0 + JAd.transpose() * JJt.partialPivLu().solve(r - JAd * y0);
      } else {
        y = JAd.transpose() * JJt.partialPivLu().solve(r);
      }
      Vec u = B * y + nle + J.transpose() * h;
      log_q[k] = q;
      if (k == N) break;
      for (int s = 0; s < nsub; ++s) {  // RK4, u held
        Vec a1 = accel(q, qd, u);
        Vec v2 = qd + 0.5 * dt * a1;
        Vec a2 = accel(q + 0.5 * dt * qd, v2, u);
        Vec v3 = qd + 0.5 * dt * a2;
        Vec a3 = accel(q + 0.5 * dt * v2, v3, u);
        Vec v4 = qd + dt * a3;
        Vec a4 = accel(q + dt * v3, v4, u);
        q += dt / 6.0 * (qd + 2.0 * v2 + 2.0 * v3 + v4);
        qd += dt / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4);
      }
    }
    times.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / (N + 1) * 1e6);
  }
  std::vector<double> sorted = times;
  std::sort(sorted.begin(), sorted.end());
  std::cout << "us_per_step " << sorted[sorted.size() / 2] << " " << sorted.front() << "\n";
  std::ofstream out(argv[2]);
  out.precision(17);
  for (const Vec& q : log_q) {
    for (int i = 0; i < n; ++i) out << q[i] << (i + 1 < n ? " " : "\n");
  }
  return 0;
}
