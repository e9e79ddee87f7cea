/**
 * @file office_dialog.h
 * @brief The paper's office request space for the dialog tests: DialogSpec names nothing by
 * default (a building's names come from its knowledge base), so tests that check the paper's
 * 3 x 5 x 2 dialog name its items, rooms and persons here, once.
 */
#pragma once

#include "krr_core/dialog/dialog_pomdp.h"

namespace krr {
namespace dialog {
namespace test {

/// @brief coke coffee soda / room1..room5 / alice bob, every other field DialogSpec's default.
inline DialogSpec officeSpec() {
  DialogSpec spec;
  spec.items = {"coke", "coffee", "soda"};
  spec.rooms = {"room1", "room2", "room3", "room4", "room5"};
  spec.persons = {"alice", "bob"};
  return spec;
}

}  // namespace test
}  // namespace dialog
}  // namespace krr
