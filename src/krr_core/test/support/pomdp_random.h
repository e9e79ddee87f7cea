/**
 * @file pomdp_random.h
 * @brief The seeded random POMDPs of the point-based solver's tests (bound sanity, pruning):
 * one generator, so that both tests exercise the same models for the same seed.
 */
#pragma once

#include <Eigen/Dense>

#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {
namespace test {

/// @brief A seeded random POMDP: each row of T has up to 3 successors and each row of O up to
/// 2 observations (random weights), rewards uniform in [-10, 10], discount 0.95; small enough
/// to solve in a moment, rich enough to need many vectors and sawtooth points.
inline Model randomSparseModel(std::uint64_t seed, std::size_t S, std::size_t A, std::size_t O) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto row = [&](std::size_t n, std::size_t support) {
    Eigen::VectorXd r = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(n));
    for (std::size_t k = 0; k < support; ++k) r(static_cast<Eigen::Index>(rng() % n)) += u(rng);
    if (r.sum() == 0.0) r(0) = 1.0;
    return Eigen::VectorXd(r / r.sum());
  };
  std::vector<Eigen::MatrixXd> t, z;
  for (std::size_t a = 0; a < A; ++a) {
    Eigen::MatrixXd ta(S, S), za(S, O);
    for (std::size_t s = 0; s < S; ++s) {
      ta.row(static_cast<Eigen::Index>(s)) = row(S, 3).transpose();
      za.row(static_cast<Eigen::Index>(s)) = row(O, 2).transpose();
    }
    t.push_back(ta);
    z.push_back(za);
  }
  Eigen::MatrixXd r(S, A);
  for (std::size_t s = 0; s < S; ++s)
    for (std::size_t a = 0; a < A; ++a)
      r(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(a)) = 20.0 * u(rng) - 10.0;
  return Model(t, z, r, 0.95);
}

}  // namespace test
}  // namespace pomdp
}  // namespace krr
