/**
 * @file model_concept.h
 * @brief The MDP model contract as code, in the style of AI-Toolbox's `IsModel`: a detection-
 * idiom trait for C++17 and, where the compiler has concepts, the same contract as a C++20
 * concept. The generic algorithms (valueIterationView, bellmanBackup, hence R-Max's planner)
 * check their model type with it, so a model that lacks a member fails with one clear message
 * instead of a page of template errors.
 *
 * Two levels:
 *  - MdpModel (is_mdp_model_v): the tabular MDP as AI-Toolbox defines it:
 *      std::size_t getS() const, std::size_t getA() const, double getDiscount() const,
 *      double getTransitionProbability(StateId s, ActionId a, StateId s1) const,
 *      double getExpectedReward(StateId s, ActionId a) const.
 *  - SuccessorModel (is_successor_model_v): an MdpModel that also lists the successors of a
 *    pair and marks terminal states, which is what the sweeps of value iteration read:
 *      bool isTerminal(StateId s) const,
 *      successors(StateId s, ActionId a) const: a range of Outcome {state, probability}.
 *
 * SparseModel and RMaxModel are SuccessorModels; GridModel / GridModelF (the navigation task's
 * fast layout) are MdpModels with their own solver (test_model_concept checks all four).
 */
#pragma once

#include <cstddef>
#include <type_traits>
#include <utility>
#if defined(__cpp_concepts) && __cpp_concepts >= 201907L
#include <concepts>
#endif

#include "krr_core/mdp/types.h"

namespace krr {
namespace mdp {

namespace detail {

template <class...>
using void_t = void;

template <class M, class = void>
struct HasMdpMembers : std::false_type {};

template <class M>
struct HasMdpMembers<
    M, void_t<decltype(std::declval<const M&>().getS()), decltype(std::declval<const M&>().getA()),
              decltype(std::declval<const M&>().getDiscount()),
              decltype(std::declval<const M&>().getTransitionProbability(
                  std::declval<StateId>(), std::declval<ActionId>(), std::declval<StateId>())),
              decltype(std::declval<const M&>().getExpectedReward(std::declval<StateId>(),
                                                                  std::declval<ActionId>()))>>
    : std::integral_constant<
          bool,
          std::is_convertible<decltype(std::declval<const M&>().getS()), std::size_t>::value &&
              std::is_convertible<decltype(std::declval<const M&>().getA()), std::size_t>::value &&
              std::is_convertible<decltype(std::declval<const M&>().getDiscount()), double>::value &&
              std::is_convertible<decltype(std::declval<const M&>().getTransitionProbability(
                                      std::declval<StateId>(), std::declval<ActionId>(),
                                      std::declval<StateId>())),
                                  double>::value &&
              std::is_convertible<decltype(std::declval<const M&>().getExpectedReward(
                                      std::declval<StateId>(), std::declval<ActionId>())),
                                  double>::value> {};

template <class M, class = void>
struct HasSuccessorMembers : std::false_type {};

template <class M>
struct HasSuccessorMembers<
    M, void_t<decltype(std::declval<const M&>().isTerminal(std::declval<StateId>())),
              decltype(std::declval<const M&>()
                           .successors(std::declval<StateId>(), std::declval<ActionId>())
                           .begin()),
              decltype(std::declval<const M&>()
                           .successors(std::declval<StateId>(), std::declval<ActionId>())
                           .end())>>
    : std::integral_constant<
          bool,
          std::is_convertible<decltype(std::declval<const M&>().isTerminal(
                                  std::declval<StateId>())),
                              bool>::value &&
              std::is_convertible<decltype(*std::declval<const M&>()
                                                .successors(std::declval<StateId>(),
                                                            std::declval<ActionId>())
                                                .begin()),
                                  Outcome>::value> {};

}  // namespace detail

/// @brief Whether M has the tabular MDP interface (see the file comment).
template <class M>
struct is_mdp_model : detail::HasMdpMembers<M> {};
template <class M>
inline constexpr bool is_mdp_model_v = is_mdp_model<M>::value;

/// @brief Whether M is an MDP model that also lists successors and terminal states.
template <class M>
struct is_successor_model
    : std::integral_constant<bool, is_mdp_model_v<M> && detail::HasSuccessorMembers<M>::value> {};
template <class M>
inline constexpr bool is_successor_model_v = is_successor_model<M>::value;

#if defined(__cpp_concepts) && __cpp_concepts >= 201907L
/// @brief C++20 spelling of is_mdp_model_v.
template <class M>
concept MdpModel = requires(const M& m, StateId s, ActionId a) {
  { m.getS() } -> std::convertible_to<std::size_t>;
  { m.getA() } -> std::convertible_to<std::size_t>;
  { m.getDiscount() } -> std::convertible_to<double>;
  { m.getTransitionProbability(s, a, s) } -> std::convertible_to<double>;
  { m.getExpectedReward(s, a) } -> std::convertible_to<double>;
};
/// @brief C++20 spelling of is_successor_model_v.
template <class M>
concept SuccessorModel = MdpModel<M> && requires(const M& m, StateId s, ActionId a) {
  { m.isTerminal(s) } -> std::convertible_to<bool>;
  { *m.successors(s, a).begin() } -> std::convertible_to<Outcome>;
  m.successors(s, a).end();
};
#endif

}  // namespace mdp
}  // namespace krr
