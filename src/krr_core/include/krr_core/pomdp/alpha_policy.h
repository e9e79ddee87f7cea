/**
 * @file alpha_policy.h
 * @brief A value-function policy: a set of alpha vectors, each labelled with an action.
 *
 * This is what the point-based solver produces and what the dialog controller executes: the
 * action of the alpha vector with the highest value at the current belief. It is saved in a
 * small text format of our own (load/save) and written in the APPL/SARSOP policy XML format so
 * that APPL's tools (polsim, polgraph) can read our policies and we can compare with theirs.
 */
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include <Eigen/Dense>

#include "krr_core/pomdp/model.h"

namespace krr {
namespace pomdp {

/// @brief Piecewise-linear convex value function V(b) = max_i alpha_i . b with actions.
class AlphaVectorPolicy {
 public:
  /// @brief An empty policy over numStates states.
  explicit AlphaVectorPolicy(std::size_t numStates = 0);

  /// @brief Add one vector. @throws ConfigError on a size mismatch or non-finite entry.
  void add(const Eigen::VectorXd& alpha, std::size_t action);

  std::size_t numStates() const { return s_; }
  std::size_t size() const { return actions_.size(); }
  const Eigen::VectorXd& alpha(std::size_t i) const { return alphas_[i]; }
  std::size_t action(std::size_t i) const { return actions_[i]; }

  /// @brief Index of the best vector at b (lowest index on ties). @throws ConfigError if empty.
  std::size_t bestIndex(const Belief& b) const;
  /// @brief The action to take at b.
  std::size_t bestAction(const Belief& b) const { return actions_[bestIndex(b)]; }
  /// @brief max_i alpha_i . b (a lower bound on the optimal value when from the solver).
  double value(const Belief& b) const;

  /// @brief Own text format: "krr-alpha-policy 1", "states S", "vectors N", then N lines
  /// "action v1 ... vS". Exact round trip (17 significant digits).
  std::string toText() const;
  static AlphaVectorPolicy fromText(const std::string& text, const std::string& file = "<string>");
  void save(const std::string& path) const;
  static AlphaVectorPolicy load(const std::string& path);

  /// @brief APPL/SARSOP policy XML (type="value", numObsValue="1", obsValue="0").
  std::string toApplXml(const std::string& modelName) const;
  void writeApplXml(const std::string& path, const std::string& modelName) const;
  /// @brief Read an APPL policy XML (as written by SARSOP or toApplXml).
  /// @throws ParseError with file:line:col.
  static AlphaVectorPolicy fromApplXml(const std::string& text,
                                       const std::string& file = "<string>");

 private:
  std::size_t s_;
  std::vector<Eigen::VectorXd> alphas_;
  std::vector<std::size_t> actions_;
};

}  // namespace pomdp
}  // namespace krr
