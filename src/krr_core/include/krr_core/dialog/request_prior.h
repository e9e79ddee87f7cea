/**
 * @file request_prior.h
 * @brief The dialog's vocabulary and initial belief, computed by P-log reasoning.
 *
 * The domain knowledge base (config/office.plog) declares the sorts item, room and person and
 * the hidden request request(I, R, P) with its random attributes and pr-atoms ("people request
 * deliveries to their own offices with probability 0.8"). The prior over the |I| |R| |P|
 * requests is P(request(I, R, P)) for every combination, asked of the reasoner, not written by
 * hand; it is normalised over the requests (worlds without a request carry no mass).
 */
#pragma once

#include <string>

#include "krr_core/plog/reasoner.h"
#include "krr_core/dialog/dialog_pomdp.h"

namespace krr {
namespace dialog {

/**
 * @brief A DialogSpec whose items, rooms, persons and prior come from `kb` (other fields keep
 * their defaults; the caller sets accuracies, costs and the delivery matrix).
 * @param kbName names the knowledge base in error messages.
 * @throws UnknownSymbolError if a sort is missing, ConfigError if every request has probability
 * zero, IncoherentError from the reasoner.
 */
DialogSpec dialogSpecFromKnowledge(plog::Reasoner& kb, const std::string& kbName);

}  // namespace dialog
}  // namespace krr
