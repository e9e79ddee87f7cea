#include "krr_core/dialog/request_prior.h"

#include "krr_core/common/errors.h"

namespace krr {
namespace dialog {

DialogSpec dialogSpecFromKnowledge(plog::Reasoner& kb, const std::string& kbName) {
  DialogSpec spec;
  try {
    spec.items = kb.sortValues("item");
    spec.rooms = kb.sortValues("room");
    spec.persons = kb.sortValues("person");
  } catch (const UnknownSymbolError& e) {
    throw UnknownSymbolError(kbName + ": the dialog needs the sorts item, room and person: " +
                             e.what());
  }
  spec.prior.resize(static_cast<Eigen::Index>(spec.items.size() * spec.rooms.size() *
                                              spec.persons.size()));
  Eigen::Index s = 0;  // request index (item * |R| + room) * |P| + person
  for (const auto& i : spec.items)
    for (const auto& r : spec.rooms)
      for (const auto& p : spec.persons)
        spec.prior(s++) = kb.probability("?{request(" + i + "," + r + "," + p + ")}");
  const double total = spec.prior.sum();
  if (!(total > 0))
    throw ConfigError(kbName + ": P(request(I,R,P)) is zero for every request");
  spec.prior /= total;
  return spec;
}

}  // namespace dialog
}  // namespace krr
