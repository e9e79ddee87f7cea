/**
 * @file pomdp_expect.h
 * @brief The one model-equality check of the POMDP file tests (.pomdp and .pomdpx round trips),
 * so that both readers are held to the same definition of "the same model".
 */
#pragma once

#include <gtest/gtest.h>

#include <cstddef>

#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {
namespace test {

/// @brief Sizes, names and discount equal; b0, R, T and O equal within tol (0 = exactly).
inline void expectSameModel(const Model& a, const Model& b, double tol = 0.0) {
  ASSERT_EQ(a.getS(), b.getS());
  ASSERT_EQ(a.getA(), b.getA());
  ASSERT_EQ(a.getO(), b.getO());
  EXPECT_EQ(a.getDiscount(), b.getDiscount());
  EXPECT_EQ(a.stateNames(), b.stateNames());
  EXPECT_EQ(a.actionNames(), b.actionNames());
  EXPECT_EQ(a.observationNames(), b.observationNames());
  EXPECT_LE((a.initialBelief() - b.initialBelief()).cwiseAbs().maxCoeff(), tol);
  EXPECT_LE((a.rewardMatrix() - b.rewardMatrix()).cwiseAbs().maxCoeff(), tol);
  for (std::size_t k = 0; k < a.getA(); ++k) {
    EXPECT_LE((a.denseTransition(k) - b.denseTransition(k)).cwiseAbs().maxCoeff(), tol)
        << "action " << k;
    EXPECT_LE((a.denseObservation(k) - b.denseObservation(k)).cwiseAbs().maxCoeff(), tol)
        << "action " << k;
  }
}

}  // namespace test
}  // namespace pomdp
}  // namespace krr
