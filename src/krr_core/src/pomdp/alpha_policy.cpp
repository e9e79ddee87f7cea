#include "krr_core/pomdp/alpha_policy.h"

#include <sstream>

#include "krr_core/common/errors.h"
#include "krr_core/common/files.h"
#include "policy_text.h"

namespace krr {
namespace pomdp {

namespace {

using detail::fmt;
using detail::locationOf;
using detail::parseDouble;
using detail::parseInt;
using detail::Tok;
using detail::tokenize;

/// Value of attribute name inside the tag text [tagBegin, tagEnd); npos if missing.
std::string attribute(const std::string& text, std::size_t tagBegin, std::size_t tagEnd,
                      const std::string& name, std::size_t* valueOffset) {
  std::size_t p = text.find(name + "=\"", tagBegin);
  if (p == std::string::npos || p >= tagEnd) return std::string("\x01");
  std::size_t v = p + name.size() + 2;
  std::size_t q = text.find('"', v);
  if (q == std::string::npos || q > tagEnd) return std::string("\x01");
  if (valueOffset) *valueOffset = v;
  return text.substr(v, q - v);
}

}  // namespace

AlphaVectorPolicy::AlphaVectorPolicy(std::size_t numStates) : s_(numStates) {}

void AlphaVectorPolicy::add(const Eigen::VectorXd& alpha, std::size_t action) {
  if (static_cast<std::size_t>(alpha.size()) != s_)
    throw ConfigError("alpha vector has " + std::to_string(alpha.size()) + " entries, policy has " +
                      std::to_string(s_) + " states");
  if (!alpha.allFinite()) throw ConfigError("alpha vector has non-finite entries");
  alphas_.push_back(alpha);
  actions_.push_back(action);
}

std::size_t AlphaVectorPolicy::bestIndex(const Belief& b) const {
  if (alphas_.empty()) throw ConfigError("alpha-vector policy is empty");
  if (static_cast<std::size_t>(b.size()) != s_)
    throw ConfigError("belief has " + std::to_string(b.size()) + " entries, policy has " +
                      std::to_string(s_) + " states");
  std::size_t best = 0;
  double bv = alphas_[0].dot(b);
  for (std::size_t i = 1; i < alphas_.size(); ++i) {
    double v = alphas_[i].dot(b);
    if (v > bv) {
      bv = v;
      best = i;
    }
  }
  return best;
}

double AlphaVectorPolicy::value(const Belief& b) const { return alphas_[bestIndex(b)].dot(b); }

std::string AlphaVectorPolicy::toText() const {
  std::ostringstream ss;
  ss << "krr-alpha-policy 1\nstates " << s_ << "\nvectors " << alphas_.size() << "\n";
  for (std::size_t i = 0; i < alphas_.size(); ++i) {
    ss << actions_[i];
    for (Eigen::Index k = 0; k < alphas_[i].size(); ++k) ss << ' ' << fmt(alphas_[i](k));
    ss << '\n';
  }
  return ss.str();
}

AlphaVectorPolicy AlphaVectorPolicy::fromText(const std::string& text, const std::string& file) {
  detail::TokenReader in(text, file);
  in.keyword("krr-alpha-policy");
  const Tok& ver = in.need("version");
  if (parseInt(ver, text, file) != 1) throw in.errorAt(ver, "unsupported version '" + ver.text + "'");
  in.keyword("states");
  const auto s = static_cast<std::size_t>(in.count("state count"));
  in.keyword("vectors");
  const auto n = static_cast<std::size_t>(in.count("vector count"));
  AlphaVectorPolicy p(s);
  for (std::size_t v = 0; v < n; ++v) {
    const auto a = static_cast<std::size_t>(in.integer("action"));
    Eigen::VectorXd alpha(static_cast<Eigen::Index>(s));
    for (std::size_t k = 0; k < s; ++k) alpha(static_cast<Eigen::Index>(k)) = in.number("value");
    p.add(alpha, a);
  }
  in.finish();
  return p;
}

void AlphaVectorPolicy::save(const std::string& path) const { writeFileAtomic(path, toText()); }

AlphaVectorPolicy AlphaVectorPolicy::load(const std::string& path) {
  return fromText(readFile(path), path);
}

std::string AlphaVectorPolicy::toApplXml(const std::string& modelName) const {
  std::ostringstream ss;
  ss << "<?xml version=\"1.0\" encoding=\"ISO-8859-1\"?>\n";
  ss << "<Policy version=\"0.1\" type=\"value\" model=\"" << modelName
     << "\" xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\" "
        "xsi:noNamespaceSchemaLocation=\"policyx.xsd\">\n";
  ss << "<AlphaVector vectorLength=\"" << s_ << "\" numObsValue=\"1\" numVectors=\""
     << alphas_.size() << "\">\n";
  for (std::size_t i = 0; i < alphas_.size(); ++i) {
    ss << "<Vector action=\"" << actions_[i] << "\" obsValue=\"0\">";
    for (Eigen::Index k = 0; k < alphas_[i].size(); ++k) ss << fmt(alphas_[i](k)) << ' ';
    ss << "</Vector>\n";
  }
  ss << "</AlphaVector> </Policy>\n";
  return ss.str();
}

void AlphaVectorPolicy::writeApplXml(const std::string& path, const std::string& modelName) const {
  writeFileAtomic(path, toApplXml(modelName));
}

AlphaVectorPolicy AlphaVectorPolicy::fromApplXml(const std::string& text, const std::string& file) {
  std::size_t av = text.find("<AlphaVector");
  if (av == std::string::npos)
    throw ParseError(locationOf(text, 0, file), "no <AlphaVector> element");
  std::size_t avEnd = text.find('>', av);
  if (avEnd == std::string::npos)
    throw ParseError(locationOf(text, av, file), "unterminated <AlphaVector> tag");
  std::size_t off = av;
  std::string len = attribute(text, av, avEnd, "vectorLength", &off);
  if (len == "\x01")
    throw ParseError(locationOf(text, av, file), "<AlphaVector> lacks vectorLength");
  std::size_t s = static_cast<std::size_t>(parseInt(Tok{len, off}, text, file));
  std::string nv = attribute(text, av, avEnd, "numVectors", &off);
  long expected = nv == "\x01" ? -1 : parseInt(Tok{nv, off}, text, file);
  AlphaVectorPolicy p(s);
  std::size_t pos = avEnd;
  while (true) {
    std::size_t v = text.find("<Vector", pos);
    if (v == std::string::npos) break;
    std::size_t vEnd = text.find('>', v);
    if (vEnd == std::string::npos)
      throw ParseError(locationOf(text, v, file), "unterminated <Vector> tag");
    std::string act = attribute(text, v, vEnd, "action", &off);
    if (act == "\x01") throw ParseError(locationOf(text, v, file), "<Vector> lacks action");
    std::size_t a = static_cast<std::size_t>(parseInt(Tok{act, off}, text, file));
    std::size_t close = text.find("</Vector>", vEnd);
    if (close == std::string::npos)
      throw ParseError(locationOf(text, v, file), "<Vector> is not closed");
    auto toks = tokenize(text, vEnd + 1, close);
    if (toks.size() != s)
      throw ParseError(locationOf(text, vEnd + 1, file),
                       "<Vector> has " + std::to_string(toks.size()) + " values, expected " +
                           std::to_string(s));
    Eigen::VectorXd alpha(static_cast<Eigen::Index>(s));
    for (std::size_t k = 0; k < s; ++k) alpha(k) = parseDouble(toks[k], text, file);
    p.add(alpha, a);
    pos = close;
  }
  if (expected >= 0 && static_cast<std::size_t>(expected) != p.size())
    throw ParseError(locationOf(text, av, file),
                     "numVectors=" + std::to_string(expected) + " but " +
                         std::to_string(p.size()) + " <Vector> elements");
  return p;
}

}  // namespace pomdp
}  // namespace krr
