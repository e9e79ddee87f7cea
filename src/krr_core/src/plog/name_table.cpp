/**
 * @file name_table.cpp
 * @brief NameTable: interned names as dense ids (open addressing, linear probing).
 */
#include "krr_core/plog/name_table.h"

#include <stdexcept>

namespace krr {
namespace plog {

std::uint32_t NameTable::hashOf(std::string_view s) {
  // FNV-1a, then a final mix so that the low bits (the slot) depend on every byte
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : s) h = (h ^ c) * 1099511628211ull;
  h ^= h >> 29;
  h *= 0xbf58476d1ce4e5b9ull;
  h ^= h >> 32;
  return static_cast<std::uint32_t>(h);
}

void NameTable::reserve(std::size_t n) {
  names_.reserve(n);
  if (2 * n > slots_.size()) grow(2 * n);
}

void NameTable::clear() {
  names_.clear();
  slots_.clear();
  mask_ = 0;
}

std::size_t NameTable::slotOf(std::string_view name, std::uint32_t h) const {
  std::size_t i = h & mask_;
  for (;;) {
    const Slot& s = slots_[i];
    if (s.id1 == 0) return i;
    if (s.hash == h && names_[s.id1 - 1] == name) return i;
    i = (i + 1) & mask_;
  }
}

void NameTable::grow(std::size_t min_slots) {
  std::size_t n = 16;
  while (n < min_slots) n *= 2;
  if (n <= slots_.size()) return;
  std::vector<Slot> old;
  old.swap(slots_);
  slots_.assign(n, Slot{});
  mask_ = n - 1;
  for (const Slot& s : old) {
    if (s.id1 == 0) continue;
    std::size_t i = s.hash & mask_;
    while (slots_[i].id1 != 0) i = (i + 1) & mask_;
    slots_[i] = s;
  }
}

int NameTable::intern(std::string_view name) {
  if (2 * (names_.size() + 1) > slots_.size()) grow(2 * (names_.size() + 1));
  const std::uint32_t h = hashOf(name);
  const std::size_t i = slotOf(name, h);
  if (slots_[i].id1 != 0) return static_cast<int>(slots_[i].id1 - 1);
  if (names_.size() >= 0xffffffffu - 1) throw std::length_error("NameTable: too many names");
  names_.emplace_back(name);
  slots_[i] = Slot{h, static_cast<std::uint32_t>(names_.size())};
  return static_cast<int>(names_.size() - 1);
}

int NameTable::find(std::string_view name) const {
  if (slots_.empty()) return -1;
  const Slot& s = slots_[slotOf(name, hashOf(name))];
  return s.id1 == 0 ? -1 : static_cast<int>(s.id1 - 1);
}

std::shared_ptr<const AttributeNames> AttributeNames::make(
    const std::vector<AttributeDecl>& decls) {
  NameTable names;
  names.reserve(decls.size());
  for (std::size_t i = 0; i < decls.size(); ++i)
    if (static_cast<std::size_t>(names.intern(decls[i].name)) != i) return nullptr;
  return std::make_shared<const AttributeNames>(std::move(names));
}

bool AttributeNames::indexes(const std::vector<AttributeDecl>& decls) const {
  if (decls.size() != names_.size()) return false;
  for (std::size_t i = 0; i < decls.size(); ++i)
    if (names_.name(static_cast<int>(i)) != decls[i].name) return false;
  return true;
}

AttributeIndex::AttributeIndex(const Program& program, bool last_wins)
    : attributes_(&program.attributes) {
  if (program.attribute_names && program.attribute_names->indexes(program.attributes)) {
    shared_ = program.attribute_names;  // distinct names: first and last declaration agree
    return;
  }
  names_.reserve(program.attributes.size());
  decl_.reserve(program.attributes.size());
  for (std::size_t i = 0; i < program.attributes.size(); ++i) {
    const int id = names_.intern(program.attributes[i].name);
    if (static_cast<std::size_t>(id) == decl_.size()) {
      decl_.push_back(static_cast<int>(i));
    } else {
      hints_ = false;  // a name declared twice: the hint may name either declaration
      if (last_wins) decl_[static_cast<std::size_t>(id)] = static_cast<int>(i);
    }
  }
}

}  // namespace plog
}  // namespace krr
