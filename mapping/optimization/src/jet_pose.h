// Pose arithmetic on Jets for the cost functions that differentiate over the tangent
// (inertial_residual.cpp, pose_graph.cpp). Private to mapping/optimization.
#pragma once

#include <ceres/rotation.h>

namespace vilma::mapping {

// Quaternions here are w-first arrays (ceres/rotation.h); pose blocks store x y z w.
template <typename T>
inline void Conjugate(const T* q, T* out) {
  out[0] = q[0];
  out[1] = -q[1];
  out[2] = -q[2];
  out[3] = -q[3];
}

// x ⊞ δ of a pose block: p + δp, q ⊗ Exp(δθ); q out w-first.
template <typename T>
inline void PlusPose(const double* x, const T* delta, T* p, T* q) {
  for (int k = 0; k < 3; ++k) p[k] = T(x[k]) + delta[k];
  const T q0[4] = {T(x[6]), T(x[3]), T(x[4]), T(x[5])};
  T dq[4];
  ceres::AngleAxisToQuaternion(delta + 3, dq);
  ceres::QuaternionProduct(q0, dq, q);
}

template <typename T>
inline void RotateInverse(const T* q, const T* v, T* out) {  // R(q)ᵀ v
  T qc[4];
  Conjugate(q, qc);
  ceres::UnitQuaternionRotatePoint(qc, v, out);
}

}  // namespace vilma::mapping
