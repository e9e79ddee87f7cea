/**
 * @file tiger.h
 * @brief The Tiger problem (Kaelbling, Littman & Cassandra 1998), the canonical POMDP test.
 *
 * States tiger-left / tiger-right; actions listen / open-left / open-right; observations
 * tiger-left / tiger-right (what is heard). Listening costs 1 and reports the tiger's side
 * correctly with the given accuracy; opening the tiger's door costs 100, the other door gives
 * +10, and opening resets the problem (uniform state, uninformative observation).
 * A toy problem for tests and benchmarks (examples library), built as a pomdp::Model.
 */
#pragma once

#include "krr_core/pomdp/model.h"

namespace krr {
namespace examples {

/// @brief Tiger with the standard numbers by default (accuracy 0.85, discount 0.95).
pomdp::Model makeTiger(double discount = 0.95, double listenAccuracy = 0.85,
                       double listenCost = 1.0, double treasureReward = 10.0,
                       double tigerPenalty = 100.0);

}  // namespace examples
}  // namespace krr
