/**
 * @file name_table.h
 * @brief Interned names (attributes, sorts, constants) as dense integer ids, for the hot paths of
 * the P-log front end: resolution, relevance cones, grounding and the reasoner's bookkeeping
 * look names up once per occurrence, and a program of 10^5 statements makes as many names.
 *
 * Open addressing with linear probing over a power-of-two table of (hash, id) pairs: a lookup
 * reads one slot (8 bytes, usually one cache line) and compares the one name whose hash
 * matches, instead of walking a node list as std::unordered_map<std::string, int> does.
 */
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "krr_core/plog/ast.h"

namespace krr {
namespace plog {

class NameTable {
 public:
  NameTable() = default;
  /// @brief Room for `n` names without rehashing.
  void reserve(std::size_t n);
  /// @brief The id of `name`, added with the next id (size() before the call) when absent.
  int intern(std::string_view name);
  /// @brief The id of `name`, or -1 when absent.
  int find(std::string_view name) const;
  /// @brief Starts loading the slot of `name` into the cache, nothing else: a caller that
  /// interns many names in a row names one a few steps ahead, so that the table's cache miss
  /// (once it holds 10^5 names) overlaps the work in between.
  void prefetch(std::string_view name) const {
    if (!slots_.empty()) __builtin_prefetch(&slots_[hashOf(name) & mask_]);
  }
  /// @brief The name of an id (0 <= id < size()).
  const std::string& name(int id) const { return names_[static_cast<std::size_t>(id)]; }
  /// @brief Number of names; ids are 0 .. size() - 1 in the order they were added.
  std::size_t size() const { return names_.size(); }
  bool empty() const { return names_.empty(); }
  void clear();

 private:
  static std::uint32_t hashOf(std::string_view s);
  /// @brief Slot of `name`, or the empty slot where it would go (slots_ must not be empty).
  std::size_t slotOf(std::string_view name, std::uint32_t h) const;
  void grow(std::size_t min_slots);

  struct Slot {
    std::uint32_t hash = 0;  ///< the name's hash (valid where id1 != 0)
    std::uint32_t id1 = 0;   ///< id + 1; 0: empty
  };
  std::vector<std::string> names_;
  std::vector<Slot> slots_;  ///< a power of two of them (or none), at most half full
  std::size_t mask_ = 0;     ///< slots_.size() - 1
};

/**
 * @brief The names of a program's attributes, interned once by the parser and kept on the
 * program (Program::attribute_names) so that the later passes (the reasoner's bookkeeping, the
 * relevance cone, the grounder) share one table: building one table of 10^5 names per pass
 * cost a cache miss per name each time.
 *
 * Name id i is declaration i: only made for declarations whose names are distinct. Immutable
 * once made, so copies of a program share it.
 */
class AttributeNames {
 public:
  /// @brief Takes `names`, whose id i must be the name of declaration i of the program.
  explicit AttributeNames(NameTable names) : names_(std::move(names)) {}
  /// @brief The names of `decls`, nullptr when a name is declared twice.
  static std::shared_ptr<const AttributeNames> make(const std::vector<AttributeDecl>& decls);
  /// @brief True when id i names decls[i] for every declaration and no other name is held:
  /// one pass in order over both (no hashing), which a copy of a program edited by hand fails.
  bool indexes(const std::vector<AttributeDecl>& decls) const;
  /// @brief Declaration index of `name`, -1 when absent.
  int find(std::string_view name) const { return names_.find(name); }
  std::size_t size() const { return names_.size(); }

 private:
  NameTable names_;
};

/**
 * @brief The attributes of a program by name, for the passes over a resolved program (cones,
 * grounding, the reasoner's bookkeeping): of(term) answers from the term's hint
 * (AttributeTerm::index) when it names the same attribute, so that the passes do not hash a
 * name per atom; find(name) looks the name up.
 *
 * The table is the program's Program::attribute_names when that still indexes its
 * declarations, else made here. A program that declares a name twice (the parser never makes
 * one) is indexed without hints: its duplicates map to the first declaration, or with
 * `last_wins` to the last one.
 */
class AttributeIndex {
 public:
  explicit AttributeIndex(const Program& program, bool last_wins = false);
  /// @brief Declaration index of `name`, -1 when undeclared.
  int find(const std::string& name) const {
    if (shared_) return shared_->find(name);
    const int id = names_.find(name);
    return id < 0 ? -1 : decl_[static_cast<std::size_t>(id)];
  }
  /// @brief Declaration index of the term's attribute, -1 when undeclared.
  int of(const AttributeTerm& t) const {
    if (hints_ && t.index >= 0 && static_cast<std::size_t>(t.index) < attributes_->size() &&
        (*attributes_)[static_cast<std::size_t>(t.index)].name == t.name)
      return t.index;
    return find(t.name);
  }
  /// @brief Number of declarations indexed.
  std::size_t size() const { return attributes_->size(); }
  /// @brief False when a name is declared twice (then of() always looks the name up).
  bool usesHints() const { return hints_; }
  /// @brief True when the program's shared table was used (no name was hashed here).
  bool shared() const { return shared_ != nullptr; }

 private:
  const std::vector<AttributeDecl>* attributes_;
  std::shared_ptr<const AttributeNames> shared_;  ///< the program's table, when valid
  NameTable names_;        ///< otherwise: made here
  std::vector<int> decl_;  ///< name id -> declaration index (with names_)
  bool hints_ = true;
};

}  // namespace plog
}  // namespace krr
