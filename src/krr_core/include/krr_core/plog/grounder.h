/**
 * @file grounder.h
 * @brief Relevance-restricted grounding of a P-log program for the native exact reasoner.
 *
 * The grounder splits the attributes of the program into STATIC ones (no random attribute
 * among their ancestors: evaluated once, bottom-up, into an indexed fact store) and DYNAMIC
 * ones (random attributes and the attributes derived from them). Only dynamic attribute
 * instances become nodes of the ground network; static literals are evaluated during grounding
 * (joins over the indexed facts, never nested enumeration of sort values when a fact binds a
 * variable), so ground bodies contain dynamic literals only.
 */
#pragma once

#include <memory>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "krr_core/plog/ast.h"

namespace krr {
namespace plog {

/// @brief Interned ground values (symbols, integers, compound values) of one grounding.
class SymbolTable {
 public:
  /// @brief Id of the value written as `text` (integers as decimal text).
  int intern(const std::string& text);
  int internInt(long long v);
  const std::string& text(int id) const { return texts_[static_cast<size_t>(id)]; }
  /// @brief True when the value is an integer (then *v receives it).
  bool isInt(int id, long long* v = nullptr) const;
  size_t size() const { return texts_.size(); }

 private:
  std::vector<std::string> texts_;
  std::vector<char> is_int_;
  std::vector<long long> ints_;
  std::unordered_map<std::string, int> ids_;
};

/// @brief A ground dynamic literal over an instance of the ground network.
/// The atom is "instance has value domain[value]"; `neg`: the instance has a value other than
/// domain[value]; `naf`: default negation of the (possibly negated) atom.
struct GLit {
  int inst = 0;
  int value = 0;  ///< index into the instance's domain
  bool naf = false;
  bool neg = false;
};

/// @brief A random selection rule of one instance, ground.
struct GSelection {
  std::string label;
  std::vector<GLit> body;
  bool dynamic_range = false;
  /// @brief For dynamic ranges: (value index, extra condition) pairs; a value is possible iff
  /// one of its conditions holds (empty condition = always).
  std::vector<std::pair<int, std::vector<GLit>>> range;
  SourceLocation loc;
};

/// @brief A ground pr-atom of one instance.
struct GPr {
  int value = 0;
  double probability = 0;
  std::string label;
  std::vector<GLit> body;
  SourceLocation loc;
  int priority = 0;  ///< PrAtom::priority
};

/// @brief A dynamic attribute instance a(t): a node of the ground network.
struct GInstance {
  int attr = 0;              ///< index into Program::attributes
  std::vector<int> args;     ///< symbol ids
  std::vector<int> domain;   ///< symbol ids of the range sort, in sort order
  bool random = false;
  std::vector<GSelection> selections;
  std::vector<GPr> prs;
  /// @brief Derived instances: rules (value index, body).
  std::vector<std::pair<int, std::vector<GLit>>> rules;
  std::string name;          ///< printable a(t)
  int valueIndex(int sym) const;
};

/// @brief The ground network restricted to the relevance cone of some attributes.
struct GroundProgram {
  std::shared_ptr<SymbolTable> symbols;
  std::vector<GInstance> instances;
  std::unordered_map<std::string, int> instance_ids;  ///< printable a(t) -> index
  std::vector<std::pair<std::vector<GLit>, SourceLocation>> constraints;
  /// @brief Static facts: attr index -> set of printable ground atoms "a(t)=y" that hold.
  std::vector<std::set<std::string>> static_atoms;
  std::vector<bool> attr_dynamic;   ///< per Program::attributes
  std::vector<bool> attr_random;
  std::vector<bool> attr_in_cone;
  size_t ground_statements = 0;     ///< number of ground dynamic statements produced

  /// @brief Index of the instance a(t) or -1 (not dynamic / not in the cone).
  int findInstance(const std::string& printable) const;
  /// @brief Truth of a static ground atom "a(t)=y" (false when not derived).
  bool staticHolds(int attr, const std::string& printable_atom) const;
};

/// @brief Ground the part of `program` relevant to `cone_attributes` (names; their ancestors
/// are added automatically, and so are constraints and attributes that could get two values in
/// a world, which act as evidence, with their ancestors).
/// @throws krr::Error for programs outside the native fast path (rules defining random
/// attributes, negative cycles among static attributes), UnknownSymbolError for variables
/// whose sort cannot be determined, IncoherentError for static attributes with two values.
GroundProgram groundProgram(const Program& program, const std::set<std::string>& cone_attributes);

/// @brief All attributes the named ones depend on (the relevance cone), names included.
std::set<std::string> relevanceCone(const Program& program, const std::set<std::string>& names);

}  // namespace plog
}  // namespace krr
