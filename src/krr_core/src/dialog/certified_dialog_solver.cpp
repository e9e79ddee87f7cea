#include "krr_core/dialog/certified_dialog_solver.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <unordered_map>

#include "krr_core/common/errors.h"
#include "krr_core/common/limits.h"
#include "krr_core/common/random.h"
#include "krr_core/common/resources.h"

namespace krr {
namespace dialog {

const char* toString(SolveStop s) {
  switch (s) {
    case SolveStop::kRunning: return "running";
    case SolveStop::kPrecision: return "precision";
    case SolveStop::kTrials: return "trial budget";
    case SolveStop::kTimeout: return "timeout";
    case SolveStop::kMemory: return "memory budget";
  }
  return "?";
}

namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr std::size_t kNone = std::numeric_limits<std::size_t>::max();
constexpr int kSlots = 3;
constexpr std::size_t kMaxValues = 64;  // values of one slot
/// Penalty levels 1 - theta of the room-paid bound (upperRelaxation), largest first
/// (paidLevels_): theta's odds on a grid of kPaidPerDoubling steps per doubling from 1/(m-1)
/// up. A question about the room multiplies the odds by at most its likelihood ratio G, so
/// it moves the level on by a whole number of steps (exactly when G is a power of 2).
constexpr int kNumPaidLevels = 48;
constexpr int kPaidPerDoubling = 3;

/// @brief x as a float no smaller than x (upper bounds stored in floats stay upper bounds).
float floatUp(double x) {
  float f = static_cast<float>(x);
  if (static_cast<double>(f) < x) f = std::nextafter(f, std::numeric_limits<float>::infinity());
  return f;
}

/// @brief Open-addressing table of fixed-stride int16 keys -> dense indices (a 32-bit hash
/// tag beside each slot spares most key comparisons).
class KeyTable {
 public:
  explicit KeyTable(std::size_t stride) : stride_(stride) {
    slots_.assign(1024, 0);
    tags_.assign(1024, 0);
  }
  std::size_t size() const { return count_; }
  std::size_t stride() const { return stride_; }
  const std::int16_t* key(std::size_t i) const { return &keys_[i * stride_]; }
  /// Resident bytes: the keys (in use when reserved up front: untouched pages cost nothing)
  /// and the slots (rehashing touches them all).
  std::size_t bytes() const {
    return (reserved_ ? keys_.size() : keys_.capacity()) * sizeof(std::int16_t) +
           slots_.capacity() * 2 * sizeof(std::uint32_t);
  }
  /// @return false when the address space is refused (the keys then grow as needed).
  bool reserve(std::size_t entries) {
    try {
      keys_.reserve(entries * stride_);
      reserved_ = true;
    } catch (const std::exception&) {  // std::bad_alloc, std::length_error
      reserved_ = false;
    }
    return reserved_;
  }
  std::size_t bytesPerEntry() const { return stride_ * sizeof(std::int16_t) + 4 * sizeof(std::uint32_t); }

  std::size_t find(const std::int16_t* k) const {
    const std::uint64_t hv = hash(k);
    const std::uint32_t tag = static_cast<std::uint32_t>(hv >> 32);
    const std::size_t mask = slots_.size() - 1;
    for (std::size_t h = hv & mask;; h = (h + 1) & mask) {
      const std::uint32_t v = slots_[h];
      if (v == 0) return kNone;
      if (tags_[h] == tag && std::memcmp(key(v - 1), k, stride_ * sizeof(std::int16_t)) == 0) return v - 1;
    }
  }
  /// @return {index, inserted}
  std::pair<std::size_t, bool> insert(const std::int16_t* k) {
    if ((count_ + 1) * 2 > slots_.size()) grow();
    const std::uint64_t hv = hash(k);
    const std::uint32_t tag = static_cast<std::uint32_t>(hv >> 32);
    const std::size_t mask = slots_.size() - 1;
    std::size_t h = hv & mask;
    for (;; h = (h + 1) & mask) {
      const std::uint32_t v = slots_[h];
      if (v == 0) break;
      if (tags_[h] == tag && std::memcmp(key(v - 1), k, stride_ * sizeof(std::int16_t)) == 0) return {v - 1, false};
    }
    keys_.insert(keys_.end(), k, k + stride_);
    slots_[h] = static_cast<std::uint32_t>(++count_);
    tags_[h] = tag;
    return {count_ - 1, true};
  }

 private:
  std::uint64_t hash(const std::int16_t* k) const {
    std::uint64_t h = 0x243f6a8885a308d3ULL;
    for (std::size_t i = 0; i < stride_; ++i)
      h = (h ^ static_cast<std::uint16_t>(k[i])) * 0x100000001b3ULL;
    return splitMix64(h);
  }
  void grow() {
    std::vector<std::uint32_t> slots(slots_.size() * 2, 0), tags(slots_.size() * 2, 0);
    const std::size_t mask = slots.size() - 1;
    for (std::size_t i = 0; i < count_; ++i) {
      const std::uint64_t hv = hash(key(i));
      std::size_t h = hv & mask;
      while (slots[h] != 0) h = (h + 1) & mask;
      slots[h] = static_cast<std::uint32_t>(i + 1);
      tags[h] = static_cast<std::uint32_t>(hv >> 32);
    }
    slots_.swap(slots);
    tags_.swap(tags);
  }
  std::size_t stride_;
  bool reserved_ = false;
  std::size_t count_ = 0;
  std::vector<std::int16_t> keys_;
  std::vector<std::uint32_t> slots_, tags_;
};

enum class QKind { kAsk, kConfirm, kStall };

struct Question {
  QKind kind;
  int slot;
  std::size_t value;   // confirmed value
  double cost;
  std::size_t action;  // model action index
};

/// How an answer changes one slot's statistics.
struct SlotCode {
  std::size_t n = 1;          // values
  int channels = 0;           // finite log-likelihood channels (0..2)
  int askStep[2] = {0, 0};    // per channel: added to e_w for answer w to the general question
  int confStep[2] = {0, 0};   // per channel: +- for yes / no to "is it x?"
  double unit[2] = {0, 0};    // log-likelihood per unit of each channel
  bool excl = false;          // accuracies of exactly 0 or 1: values get excluded
  int width = 0;              // int16 entries per value: channels + excl
  std::size_t offset = 0;     // first entry of the slot in a key
  double pAsk = 0, pConf = 0; // accuracies
  bool askInformative = false, confInformative = false;
  std::vector<int> cls;       // symmetry class of each value (values alike in root and rewards)
  bool sortable = false;      // some class has two values or more
  std::vector<std::vector<std::size_t>> groups;  // the classes of two values or more
};

}  // namespace

class CertifiedDialogSolver::Impl {
 public:
  Impl(const DialogPomdp& dialog, const Eigen::VectorXd& root, int turnsUsed,
       CertifiedSolverOptions options);
  // --- set-up, in this order (the constructor) ---
  /// Check the options and the root belief; the serve rewards and request parts.
  void checkAndSetRoot(const Eigen::VectorXd& root);
  /// Each slot's statistics: channels, steps, widths and offsets in a key.
  void initSlots();
  /// Values of a slot alike in the root belief and every serve reward (sorted in keys).
  void initSymmetry();
  /// The questions, without duplicate experiments; uninformative ones as one stall.
  void initQuestions();
  /// The slot revealed by the upper bound, its wrong-room serves, room lookaheads and levels.
  void initRevealed();
  /// The key tables and their memory budget.
  void initTables();

  // --- the model, in the statistics' terms ---
  const DialogPomdp& d_;
  CertifiedSolverOptions o_;
  std::size_t nReq_;
  int turnsUsed_, horizon_;
  double gamma_;
  Eigen::VectorXd root_;
  Eigen::MatrixXd serveR_;                    // nReq x nReq: R(s, serve a)
  std::vector<std::array<std::size_t, kSlots>> parts_;
  SlotCode slot_[kSlots];
  std::vector<Question> questions_;
  std::size_t stride_;
  int revealed_ = 1;                          // the slot revealed by the upper bound

  // --- search ---
  struct Node {  // 24 bytes
    double upper, lower;
    std::uint32_t group;  ///< its simplex (see groupTable_), kNoGroup if none
    /// The shallowest expanded node with the same statistics when this one was created
    /// (itself if none): the optimal value never grows with fewer questions left,
    /// V_d(s) <= V_d'(s) for d' <= d, so that node's upper bound is this node's too (see
    /// effUpper). Only expanded nodes are registered (statsTable_): an unexpanded one's bound
    /// is its relaxation, no better than this node's own.
    std::uint32_t head;
  };
  std::vector<bool> expandedFlags_;           // per node: backed up from its children
  /// statistics without the turn -> the shallowest expanded node with them
  KeyTable statsTable_;
  std::vector<std::uint32_t> statsNode_;
  std::vector<std::int16_t> statsScratch_;
  KeyTable table_;
  std::vector<Node> nodes_;

  /// Nodes with the same turn and the same statistics of every slot but the revealed one
  /// (the room) differ only in the room's likelihoods, and their beliefs are the mixtures
  /// b = sum_r w_r b|r of the same corners b|r (b|r does not depend on the room's
  /// statistics). V_t is convex, so on that simplex it is a convex function of w whose corner
  /// values are the exact sub-dialog values V_r: the room-revealed bound is the linear
  /// interpolation sum_r w_r V_r. A node whose upper bound U' fell below that line by
  /// delta' = sum_r w'_r V_r - U' lowers it everywhere on the simplex (HSVI's sawtooth):
  /// writing w = rho w' + (1 - rho) z with rho = min_r w_r / w'_r,
  ///   V_t(w) <= rho U' + (1 - rho) sum_r z_r V_r = sum_r w_r V_r - rho delta'.
  /// Each simplex keeps up to kSimplexPoints such points (the largest deltas).
  static constexpr std::uint32_t kNoGroup = std::numeric_limits<std::uint32_t>::max();
  static constexpr std::size_t kSimplexPoints = 8;
  KeyTable groupTable_;              // a node key with the revealed slot's section zeroed
  /// Per simplex that has points (made when its first point is noted: most never get one),
  /// with m the revealed slot's values: Z_0..Z_{m-1} (the sum over b|r's requests of root x
  /// the other slots' likelihoods: w_r ~ Z_r lambda_r), the corner values V_0..V_{m-1}, then
  /// the points, each [node, delta, w_0 .. w_{m-1}].
  std::unordered_map<std::uint32_t, std::vector<double>> groupData_;
  std::size_t groupDataBytes_ = 0;   // their capacity, with the map's per-entry overhead
  std::size_t sharedCuts_ = 0;       // new nodes' upper bounds lowered by another node's
  /// The room weights w of node n on its simplex (data: its groupData_ entry), and the
  /// interpolation sum_r w_r V_r.
  double simplexWeights(const std::int16_t* key, const std::vector<double>& data, double* w) const;
  /// Node n's simplex data, made (corners solved) if it has none.
  std::vector<double>& groupDataOf(std::size_t n);
  /// Node n's upper bound with its simplex's sawtooth applied (valid: see groupTable_).
  double effUpper(std::size_t n) const;
  /// The shared bounds' cut of an upper bound: the head's bound (kNoHead: none) and the
  /// sawtooth of the simplex `group` at `key`, skipping node `self`'s own point.
  double sharedUpper(const std::int16_t* key, double upper, std::uint32_t group,
                     std::uint32_t head, std::size_t self) const;
  static constexpr std::uint32_t kNoHead = std::numeric_limits<std::uint32_t>::max();

  /// Children are not nodes until a trial enters them (most never are). An expanded node
  /// keeps one slot of two words per child position (posOf_: questions_ x answers): the
  /// child's bounds as floats rounded outwards (upper, lower; the shared bounds as they were
  /// when it was kept), or, once the child is a node, its index and kLinked (a backup looks
  /// up the unlinked ones: another parent may have made them nodes).
  bool leafCache_ = false;
  std::vector<std::size_t> posOf_;            // first position of question qi
  std::size_t numPos_ = 0;
  std::vector<std::uint32_t> slotChunk_, slotAt_;  // per node: where its slots are (expanded)
  static constexpr std::uint32_t kLinked = 0xffffffffu;  // a NaN pattern: never a bound
  static constexpr std::size_t kSlotChunkWords = std::size_t{1} << 20;
  std::vector<std::unique_ptr<std::uint32_t[]>> slotChunks_;
  std::size_t slotUsed_ = kSlotChunkWords;         // words used in the last chunk
  std::vector<std::uint32_t> freshSlots_;          // a first expansion's slots
  std::uint32_t* slotsOf(std::size_t n) const { return &slotChunks_[slotChunk_[n]][slotAt_[n]]; }
  /// Child bounds from a slot that does not hold a node.
  static void unpackSlot(const std::uint32_t* w, double& upper, double& lower) {
    float fu, fl;
    std::memcpy(&fu, &w[0], sizeof(float));
    std::memcpy(&fl, &w[1], sizeof(float));
    lower = fl;
    upper = std::max(fu, fl);
  }
  /// Bounds of a new belief (a node's or a kept child's): serve, relaxation, commit plans.
  void newBounds(const std::int16_t* key, int depth, const Eigen::VectorXd* hint,
                 double& upper, double& lower, std::uint32_t& group, std::uint32_t& head);
  /// After n's upper bound fell: record it as a point of its simplex.
  void notePoint(std::size_t n);
  KeyTable subTable_;                         // revealed-slot sub-dialog: exact values
  std::vector<double> subValue_;
  std::size_t rootIndex_ = 0;
  std::size_t trials_ = 0, expanded_ = 0;
  SolveStop stop_ = SolveStop::kRunning;
  double seconds_ = 0.0;
  std::size_t maxEntries_ = 0;
  /// The tables' bytes (bytes()) at which the search stops: 65 % of the memory budget, the
  /// rest for the process, the tables' growth (a hash table briefly holds its old and new
  /// slots) and the policy's export.
  std::size_t tableBudget_ = 0;
  bool nodesReserved_ = false;  // nodes_ reserved up front (bytes() counts its size)
  Rng rng_;

  // scratch
  mutable std::vector<std::int16_t> scratch_;

  // --- statistics and beliefs ---
  /// Shift each slot's statistics to minimum 0 and sort values alike; `perm` (if given)
  /// receives, per slot in order, the original value at each canonical position. skipMask:
  /// slots (bit k) left as they are (the revealed slots of a sub-dialog key).
  void canonicalize(std::int16_t* key, std::vector<std::size_t>* perm = nullptr,
                    int skipMask = 0, bool sort = true) const;
  /// The lower bound's greedy choice at a canonical key: a question index, or kNone (serve).
  std::size_t lowerChoice(const std::int16_t* canonicalKey) const;
  /// The question of a canonical choice at the actual key whose canonical permutation is perm.
  Question actualQuestion(std::size_t choice, const std::vector<std::size_t>& perm) const;
  /// Probability of reaching each actual (shifted) key under the lower bound's policy; keys
  /// below `floor` are not followed further.
  std::unordered_map<std::string, double> policyReach(double floor) const;
  /// The exported plans: vectors over requests with their action and turn, and per vector
  /// the vector continuing it after each model observation (-1: none; kServeNext - a: the
  /// "serve a" plan, appended by policy() after these).
  struct PlanExport {
    std::unordered_map<std::string, std::size_t> memo;
    std::vector<Eigen::VectorXd> vectors;
    std::vector<std::pair<std::size_t, int>> tags;
    std::vector<long> next;  // vectors.size() x obs
    std::size_t obs = 0;
  };
  static constexpr long kServeNext = -2;
  /// Index of the lower bound's plan's vector from an actual (unsorted) key.
  std::size_t planVector(const std::int16_t* key,
                         const std::unordered_map<std::string, double>& reach, double floor,
                         PlanExport& ex) const;
  /// A frontier node's plan when it beats serving (alpha, action: serving's on entry; next:
  /// its continuations): its commit plan, or a question about the room and then commit plans
  /// (see upperRelaxation).
  void frontierPlan(const std::int16_t* key, const Eigen::VectorXd& b, double reach,
                    Eigen::VectorXd& alpha, std::size_t& action, std::vector<long>& next,
                    PlanExport& ex) const;
  /// A commit plan's vectors (see upperRelaxation): r's sub-dialog plan from an actual sub
  /// key (revealed section {r, 0, ...}, the other slots in actual order, shifted), each node's
  /// vector added with its action and turn (the executor needs them all); plans end by
  /// serving below the reach floor. @return the index of the key's vector.
  std::size_t subPlanVector(const std::int16_t* subKey, double reach, double floor,
                            PlanExport& ex) const;
  /// alpha += discount x P(answer | request) x child, per request: one answer's share of a
  /// question's vector.
  void addAnswer(Eigen::VectorXd& alpha, const Question& q, std::size_t answer,
                 const Eigen::VectorXd& child) const;
  /// The model observation of answer `answer` to an actual question (ask: the value's,
  /// confirm: yes for 1, no for 0).
  std::size_t observationOf(const Question& q, std::size_t answer) const;
  /// next[o] = child for every observation the model allows after q (its answer unused).
  void continueOnAny(const Question& q, long child, std::vector<long>& next) const;
  /// Store a plan's vector with its action, turn and continuations under memo key mk;
  /// @return its index.
  std::size_t addVector(const Eigen::VectorXd& alpha, std::size_t action, int depth,
                        const std::string& mk, const std::vector<long>& next,
                        PlanExport& ex) const;
  /// Belief over requests of a key (any order of values, canonical or not); `fixedSlot` >= 0:
  /// restricted to requests whose value of that slot is `fixedValue`. @return false if empty.
  bool belief(const std::int16_t* key, Eigen::VectorXd& b, int fixedSlot = -1,
              std::size_t fixedValue = 0) const;
  void marginals(const Eigen::VectorXd& b, std::array<Eigen::VectorXd, kSlots>& m) const;
  double serveValue(const Eigen::VectorXd& b, std::size_t* best = nullptr) const;
  std::size_t numAnswers(const Question& q) const;
  /// P(answer | slot value v) of question q (confirm: answer 1 = yes, 0 = no).
  double answerLikelihood(const Question& q, std::size_t answer, std::size_t v) const;
  double answerProb(const Eigen::VectorXd& slotMarginal, const Question& q, std::size_t answer) const;
  void childKey(const std::int16_t* key, const Question& q, std::size_t answer, std::int16_t* child) const;
  /// Children of question q at a key whose marginals are m: f(probability, child key).
  template <class F>
  void forEachChild(const std::int16_t* key, const std::array<Eigen::VectorXd, kSlots>& m,
                    const Question& q, F&& f) const;
  void applyExclusion(std::int16_t* key, int k, std::size_t v, bool keepOnlyV) const;

  // --- bounds ---
  struct SubScratch {  // one per depth: the sub-dialog recursion's buffers
    std::vector<std::int16_t> own, kid;
    std::vector<std::size_t> perm;
    Eigen::VectorXd b, cb, pb;
    std::array<Eigen::VectorXd, kSlots> m;
    double accT[kNumPaidLevels], bestT[kNumPaidLevels];  // room-paid values (subT_)
    std::vector<std::size_t> kidIdx, bestKid;            // children of a question / the best
    std::vector<std::vector<std::size_t>> kidPerm, bestPerm;  // their canonical permutations
  };
  /// One question of the sub-dialog node in sc (its value; the children in sc.kidIdx /
  /// kidPerm, the room-paid sums in sc.accT).
  double subQuestion(SubScratch& sc, const Question& q, std::size_t fixed);
  /// The sub-dialog node of a key (revealed section {value, 0, ...}, the others canonical;
  /// depth = key[0]): its index in subTable_, or kNone when cut off (then *value is
  /// the full-information bound).
  std::size_t subNode(const std::int16_t* key, const Eigen::VectorXd* hint, double* value);
  /// The sub-dialog's optimal plan at a new node as a vector over every request (the plan's
  /// value when that request is the true one): subAlpha_ offset, or kNoAlpha when a child
  /// has none or the vectors' share of the memory budget is spent.
  std::uint32_t subPlanAlpha(const SubScratch& sc, int choice, std::size_t serveA);
  static constexpr int kSubServe = -1;
  static constexpr std::uint32_t kNoAlpha = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::int16_t> subChoice_;    // per sub node: question index, or kSubServe
  /// The room paid for (upperRelaxation, proof in the file comment): per sub node and level
  /// k, T_k = the value of the relaxation in which the room is known but serving earns the
  /// room-known serve minus paidLevels_[k] Y+(stats), and each question about the room
  /// moves the level on by its PaidStep. subT_[node * kNumPaidLevels + k] (floats rounded
  /// up); nodes made without it (none for the office) have none.
  std::vector<float> subT_;
  std::vector<double> paidLevels_;
  /// A kind of question about the room (cost, likelihood ratio G): after it, no room is
  /// more likely than theta G / (theta G + 1 - theta) if none was more than theta before,
  /// so level k moves on to next[k] (kNumPaidLevels: no penalty left).
  struct PaidStep {
    double cost, ratio;
    int next[kNumPaidLevels];
  };
  std::vector<PaidStep> paidSteps_;
  /// Gmax(r, r*): the best serve reward when the true room is r and the served request's
  /// room r* != r (m x m, row r), bounding every wrong-room serve.
  std::vector<double> wrongRoom_;
  /// Requests grouped by their values of the slots other than the revealed one.
  std::vector<std::vector<std::size_t>> otherGroups_;
  /// Y(stats) of the file comment: min over rooms r (with mass) and r* != r of the room-known
  /// serve at r minus Gmax(r, r*); -inf when no room pair exists.
  double roomServeMargin(const std::int16_t* ownZeroed) const;
  mutable Eigen::MatrixXd marginScratch_;
  /// Y by the statistics of the slots other than the room (turn and room zeroed): the room
  /// nodes and the turns of one statistics share it.
  KeyTable marginTable_{1};
  std::vector<double> marginValue_;
  /// A question about the room (the revealed slot) and each answer's likelihood per room
  /// value (lik[answer * m + r]): the lookahead lower bound's first step.
  struct RoomLook {
    std::size_t qi, answers;
    std::vector<double> lik;
  };
  std::vector<RoomLook> roomLooks_;
  /// The best plan "ask one question about the room, then commit to the room that is best
  /// for the answer" at belief b, where A[r] is room r's commit plan vector (next turn, in b's
  /// request order; null: room r not committed to). @return its value (-inf if none);
  /// bestLook / bestRoom (if given) receive the roomLooks_ index and each answer's room.
  double lookaheadValue(const Eigen::VectorXd& b, const double* const* A, std::size_t* bestLook,
                        std::vector<std::size_t>* bestRoom) const;
  /// theta(b): the most likely any room can become without a question about it.
  double roomCeiling(const Eigen::VectorXd& b) const;
  /// paidLevels_ and paidSteps_ for a room slot of m values (after roomLooks_).
  void initPaidLevels(std::size_t m);
  std::vector<std::uint32_t> subAlphaAt_;  // per sub node: offset in subAlpha_, or kNoAlpha
  std::vector<double> subAlpha_;
  std::vector<double> alphaBuf_;
  std::size_t alphaBudget_ = 0;            // bytes for subAlpha_
  std::vector<SubScratch> subScratch_;
  std::size_t subCapped_ = 0;  // sub-dialog values replaced by the full-information bound
  bool subCut_ = false;        // the sub-dialog hit the memory budget or the timeout
  Stopwatch created_;          // the timeout counts from construction (set-up included)
  /// upperRelaxation's last other-slots key (turn included, the room's section zero) and
  /// its sub-dialog nodes per room, at the turn (at[r]) and the next (at[kMaxValues + r]).
  static constexpr std::size_t kUnknownSub = kNone - 1;
  struct SubMemo {
    std::vector<std::int16_t> key, scratch;
    std::size_t at[2 * kMaxValues];
    std::uint32_t group = kNoGroup;
  } subMemo_;
  /// The room-revealed upper bound at a main key; commitLower (if given) receives the best
  /// "commit to one value of the revealed slot" plan's value (-inf if none).
  double upperRelaxation(const std::int16_t* key, const Eigen::VectorXd& b,
                         double* commitLower = nullptr, std::uint32_t* group = nullptr);

  /// The node of a canonical key, created if new (hint: its belief, if known).
  std::size_t nodeFor(const std::int16_t* key, int depth, const Eigen::VectorXd* hint = nullptr);
  /// Belief after `answer` to q (probability p) at belief b.
  void childBelief(const Eigen::VectorXd& b, const Question& q, std::size_t answer, double p,
                   Eigen::VectorXd& out) const;
  /// in, with each slot's values moved to their canonical positions (canonicalize's perm).
  void permuteBelief(const Eigen::VectorXd& in, const std::vector<std::size_t>& perm,
                     Eigen::VectorXd& out) const;
  struct Backup {
    std::size_t bestUpper = kNone;  // question index of the best upper Q (kNone: serve)
    std::size_t bestLower = kNone;
  };
  /// The children backup() read, per question qi: kidProb_ / kidNode_ from kidStart_[qi] to
  /// kidStart_[qi + 1] (valid until the next backup()).
  std::vector<double> kidProb_, kidUpper_, kidLower_;
  std::vector<std::size_t> kidNode_, kidStart_, kidAnswer_;  // kidNode_: kNone for a kept child
  std::vector<std::size_t> kidPos_;
  Backup backup(std::size_t n);
  void trial();
  /// Bounds of the child of n (key, belief b) after `answer` (probability p) to q, at slot
  /// position pos: from n's slots (linking a child that is now a node), or made (kept in
  /// freshSlots_ at a first expansion, else a node). @return the child's node, or kNone.
  std::size_t childBounds(const std::int16_t* key, const Eigen::VectorXd& b, const Question& q,
                          std::size_t answer, double p, std::size_t pos, std::uint32_t* slots,
                          bool makeSlots, double& cu, double& cl);
  struct {
    std::vector<std::int16_t> key;
    std::vector<std::size_t> perm;
    Eigen::VectorXd cb, pb;
  } childScratch_;
  /// A kept child's slot: floats rounded outwards (the kept bounds stay bounds).
  static void packSlot(double upper, double lower, std::uint32_t* w);
  /// max(upper, lower), counting a crossing when upper < lower beyond rounding: valid
  /// bounds never cross, so a crossing is a bug (CertifiedReport::crossings).
  double uncrossed(double upper, double lower) {
    if (upper < lower - 1e-6 * (1.0 + std::abs(lower))) ++crossings_;
    return std::max(upper, lower);
  }
  std::size_t crossings_ = 0;
  bool memoryExceeded() const;
  std::size_t bytes() const;
  bool run(std::size_t maxMore);

  double exactValue(std::int16_t* key, int depth, std::unordered_map<std::string, double>& memo,
                    std::size_t maxNodes);
};

namespace {

bool isRational(double ratio, int& p, int& q) {
  for (q = 1; q <= 12; ++q) {
    const double pr = ratio * q;
    const double r = std::round(pr);
    if (r != 0.0 && std::abs(pr - r) <= 1e-9 * std::max(1.0, std::abs(pr)) &&
        std::abs(r) <= 64.0) {
      p = static_cast<int>(r);
      return true;
    }
  }
  return false;
}

bool closeTo(double a, double b) {
  return std::abs(a - b) <= 1e-12 * std::max({1.0, std::abs(a), std::abs(b)});
}

}  // namespace

void CertifiedDialogSolver::Impl::checkAndSetRoot(const Eigen::VectorXd& root) {
  const DialogSpec& sp = d_.spec();
  if (turnsUsed_ < 0 || turnsUsed_ > sp.turnLimit)
    throw ConfigError("certified dialog solver: " + std::to_string(turnsUsed_) +
                      " questions asked, outside [0, turn limit " +
                      std::to_string(sp.turnLimit) + "]");
  if (!(o_.precision > 0.0) || !(o_.timeout >= 0.0))
    throw ConfigError("certified dialog solver: precision must be > 0 and timeout >= 0");
  if (!(o_.trialTarget >= 0.0 && o_.trialTarget <= 1.0))
    throw ConfigError("certified dialog solver: trialTarget " + std::to_string(o_.trialTarget) +
                      " must be in [0, 1] (a fraction of the precision)");
  if (!(gamma_ > 0.0 && gamma_ <= 1.0))
    throw ConfigError("certified dialog solver: discount " + std::to_string(gamma_) +
                      " outside (0, 1]");
  root_ = root.size() == 0 ? sp.prior : root;
  if (static_cast<std::size_t>(root_.size()) != nReq_ || !root_.allFinite() ||
      root_.minCoeff() < 0.0 || std::abs(root_.sum() - 1.0) > 1e-6)
    throw ConfigError("certified dialog solver: the root belief is not a distribution over the " +
                      std::to_string(nReq_) + " requests");
  root_ /= root_.sum();
  const auto& r = d_.model().rewardMatrix();
  serveR_.resize(static_cast<Eigen::Index>(nReq_), static_cast<Eigen::Index>(nReq_));
  for (std::size_t s = 0; s < nReq_; ++s)
    for (std::size_t a = 0; a < nReq_; ++a)
      serveR_(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(a)) =
          r(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(d_.serveAction(a)));
  for (std::size_t s = 0; s < nReq_; ++s) parts_.push_back(d_.requestParts(s));

}

void CertifiedDialogSolver::Impl::initSlots() {
  const DialogSpec& sp = d_.spec();
  // Statistics of each slot.
  const std::size_t sizes[kSlots] = {sp.items.size(), sp.rooms.size(), sp.persons.size()};
  std::size_t offset = 1;  // entry 0: depth
  int maxStep = 1;
  for (int k = 0; k < kSlots; ++k) {
    SlotCode& c = slot_[k];
    c.n = sizes[k];
    if (c.n > kMaxValues)
      throw ConfigError("certified dialog solver: " + std::to_string(c.n) + " values in one slot, at most " +
                        std::to_string(kMaxValues));
    c.pAsk = sp.pGeneral;
    c.pConf = sp.pYesNo;
    const bool askDegenerate = c.n >= 2 && (c.pAsk == 0.0 || c.pAsk == 1.0);
    const bool confDegenerate = c.n >= 2 && (c.pConf == 0.0 || c.pConf == 1.0);
    c.excl = askDegenerate || confDegenerate;
    double lg = 0.0, lh = 0.0;
    if (c.n >= 2 && !askDegenerate) lg = std::log(c.pAsk * (c.n - 1.0) / (1.0 - c.pAsk));
    if (c.n >= 2 && !confDegenerate) lh = std::log(c.pConf / (1.0 - c.pConf));
    if (std::abs(lg) < 1e-15) lg = 0.0;
    if (std::abs(lh) < 1e-15) lh = 0.0;
    c.askInformative = askDegenerate || lg != 0.0;
    c.confInformative = confDegenerate || lh != 0.0;
    int p = 0, q = 0;
    if (lg != 0.0 && lh != 0.0 && isRational(lg / lh, p, q)) {
      c.channels = 1;
      c.askStep[0] = p;
      c.confStep[0] = q;
      c.unit[0] = lh / q;
    } else {
      if (lg != 0.0) {
        c.askStep[c.channels] = 1;
        c.unit[c.channels++] = lg;
      }
      if (lh != 0.0) {
        c.confStep[c.channels] = 1;
        c.unit[c.channels++] = lh;
      }
    }
    for (int ch = 0; ch < c.channels; ++ch)
      maxStep = std::max({maxStep, std::abs(c.askStep[ch]), std::abs(c.confStep[ch])});
    c.width = c.channels + (c.excl ? 1 : 0);
    c.offset = offset;
    offset += c.n * static_cast<std::size_t>(c.width);
  }
  stride_ = offset;
  if (static_cast<long>(maxStep) * (horizon_ + 1) > 30000)
    throw ConfigError("certified dialog solver: turn limit " + std::to_string(sp.turnLimit) +
                      " too long for the answer statistics");

}

void CertifiedDialogSolver::Impl::initSymmetry() {
  // Symmetry classes: values v, w of a slot are alike when swapping them changes neither the
  // root belief nor any serve reward (the answer model treats all values alike already).
  for (int k = 0; k < kSlots; ++k) {
    SlotCode& c = slot_[k];
    std::vector<int> parent(c.n);
    std::iota(parent.begin(), parent.end(), 0);
    std::function<int(int)> findRoot = [&](int x) {
      return parent[x] == x ? x : parent[x] = findRoot(parent[x]);
    };
    auto swapOf = [&](std::size_t s, std::size_t v, std::size_t w) {
      auto pt = parts_[s];
      if (pt[k] == v) pt[k] = w;
      else if (pt[k] == w) pt[k] = v;
      return d_.requestIndex(pt[0], pt[1], pt[2]);
    };
    for (std::size_t v = 0; v < c.n; ++v)
      for (std::size_t w = v + 1; w < c.n; ++w) {
        if (findRoot(static_cast<int>(v)) == findRoot(static_cast<int>(w))) continue;
        bool same = true;
        for (std::size_t s = 0; s < nReq_ && same; ++s) {
          const std::size_t ss = swapOf(s, v, w);
          same = closeTo(root_(static_cast<Eigen::Index>(s)), root_(static_cast<Eigen::Index>(ss)));
          for (std::size_t a = 0; a < nReq_ && same; ++a)
            same = closeTo(serveR_(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(a)),
                           serveR_(static_cast<Eigen::Index>(ss),
                                   static_cast<Eigen::Index>(swapOf(a, v, w))));
        }
        if (same) parent[findRoot(static_cast<int>(w))] = findRoot(static_cast<int>(v));
      }
    c.cls.resize(c.n);
    for (std::size_t v = 0; v < c.n; ++v) c.cls[v] = findRoot(static_cast<int>(v));
    for (std::size_t v = 0; v < c.n; ++v) {
      std::vector<std::size_t> g;
      for (std::size_t w = 0; w < c.n; ++w)
        if (c.cls[w] == static_cast<int>(v)) g.push_back(w);
      if (g.size() >= 2) c.groups.push_back(g);
    }
    c.sortable = !c.groups.empty();
  }

}

void CertifiedDialogSolver::Impl::initQuestions() {
  const DialogSpec& sp = d_.spec();
  // Questions, without duplicates: equal experiments keep the cheapest (lowest index on ties),
  // uninformative questions are one "stall" action (the cheapest).
  std::vector<Question> all;
  for (int k = 0; k < kSlots; ++k) {
    const SlotCode& c = slot_[k];
    all.push_back({QKind::kAsk, k, 0, sp.generalCost, static_cast<std::size_t>(k)});
    for (std::size_t v = 0; v < c.n; ++v) {
      const std::size_t a = k == 0 ? d_.confirmItem(v) : k == 1 ? d_.confirmRoom(v) : d_.confirmPerson(v);
      all.push_back({QKind::kConfirm, k, v, sp.confirmCost, a});
    }
  }
  const Question* stall = nullptr;
  for (const Question& q : all) {
    const SlotCode& c = slot_[q.slot];
    const bool informative = q.kind == QKind::kAsk ? c.askInformative : c.confInformative;
    if (!informative) {
      if (!stall || q.cost < stall->cost) stall = &q;
      continue;
    }
    if (q.kind == QKind::kConfirm && c.n == 2 && q.value == 1) continue;  // = confirm value 0
    if (c.n == 2 && c.pAsk == c.pConf && c.askInformative) {
      // ask and confirm are the same experiment on a two-valued slot: keep the cheaper
      const bool askCheaper = sp.generalCost < sp.confirmCost;
      if (q.kind == QKind::kAsk && !askCheaper) continue;
      if (q.kind == QKind::kConfirm && askCheaper) continue;
    }
    questions_.push_back(q);
  }
  // Stall: some question that changes nothing. Questions on the revealed slot are stalls in
  // the sub-dialog (handled there); here only globally uninformative ones.
  if (stall) {
    Question s = *stall;
    s.kind = QKind::kStall;
    questions_.push_back(s);
  }

}

void CertifiedDialogSolver::Impl::initRevealed() {
  // The slot revealed by the upper bound: the one with most values.
  revealed_ = 0;
  for (int k = 1; k < kSlots; ++k)
    if (slot_[k].n >= slot_[revealed_].n) revealed_ = k;
  {
    const std::size_t m = slot_[revealed_].n;
    wrongRoom_.assign(m * m, -kInf);
    for (std::size_t s = 0; s < nReq_; ++s)
      for (std::size_t a = 0; a < nReq_; ++a) {
        const std::size_t r = parts_[s][revealed_], r2 = parts_[a][revealed_];
        if (r != r2) {
          double& g = wrongRoom_[r * m + r2];
          g = std::max(g, serveR_(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(a)));
        }
      }
    std::map<std::pair<std::size_t, std::size_t>, std::vector<std::size_t>> groups;
    for (std::size_t s = 0; s < nReq_; ++s) {
      std::size_t o[2], j = 0;
      for (int k = 0; k < kSlots; ++k)
        if (k != revealed_) o[j++] = parts_[s][k];
      groups[{o[0], o[1]}].push_back(s);
    }
    for (auto& g : groups) otherGroups_.push_back(std::move(g.second));
    for (std::size_t qi = 0; qi < questions_.size(); ++qi) {
      const Question& q = questions_[qi];
      if (q.slot != revealed_ || q.kind == QKind::kStall) continue;
      RoomLook L{qi, numAnswers(q), {}};
      for (std::size_t o = 0; o < L.answers; ++o)
        for (std::size_t r = 0; r < m; ++r) L.lik.push_back(answerLikelihood(q, o, r));
      roomLooks_.push_back(std::move(L));
    }
    initPaidLevels(m);
  }

}

void CertifiedDialogSolver::Impl::initTables() {
  posOf_.clear();
  for (const Question& q : questions_) {
    posOf_.push_back(numPos_);
    numPos_ += numAnswers(q);
  }
  leafCache_ = o_.keepLeaves;
  table_ = KeyTable(stride_);
  subTable_ = KeyTable(stride_);
  marginTable_ = KeyTable(stride_);
  groupTable_ = KeyTable(stride_);
  statsTable_ = KeyTable(stride_);
  subScratch_.resize(static_cast<std::size_t>(horizon_) + 2);
  for (SubScratch& sc : subScratch_) sc.kid.assign(stride_, 0);
  const std::size_t budget = o_.memoryBudget ? o_.memoryBudget : memoryBudget();
  // An eighth of the budget for the sub-dialog's plan vectors (the office's: 112 MB), the
  // rest for the tables.
  alphaBudget_ = o_.commitLower ? std::min<std::size_t>(budget / 8, std::size_t{1} << 34) : 0;
  const std::size_t perEntry = table_.bytesPerEntry() + sizeof(Node) + sizeof(double) +
                               sizeof(std::int16_t) + sizeof(std::uint32_t);
  maxEntries_ = std::max<std::size_t>(1024, (budget - alphaBudget_) / perEntry);
  if (maxEntries_ > std::numeric_limits<std::uint32_t>::max() / 4)
    maxEntries_ = std::numeric_limits<std::uint32_t>::max() / 4;
  tableBudget_ = budget / 100 * 65;
  // Reserved for the most nodes the table budget can hold, not touched: the vectors never
  // move (no old and new copy at once) and bytes() counts what is used.
  const std::size_t mostNodes = std::min(
      maxEntries_, tableBudget_ / (stride_ * sizeof(std::int16_t) + sizeof(Node)) + 1);
  nodesReserved_ = table_.reserve(mostNodes);
  if (nodesReserved_) {
    try {
      nodes_.reserve(mostNodes);
      expandedFlags_.reserve(mostNodes);
    } catch (const std::exception&) {  // a budget beyond the machine: grow as needed
      nodesReserved_ = false;
    }
  }

}

CertifiedDialogSolver::Impl::Impl(const DialogPomdp& dialog, const Eigen::VectorXd& root,
                                  int turnsUsed, CertifiedSolverOptions options)
    : d_(dialog), o_(options), nReq_(dialog.numRequests()), turnsUsed_(turnsUsed),
      horizon_(dialog.spec().turnLimit - turnsUsed), gamma_(dialog.spec().discount),
      statsTable_(1), table_(1), groupTable_(1), subTable_(1), rng_(makeRng(options.seed, "certified-dialog-solver")) {
  Stopwatch setup;
  checkAndSetRoot(root);
  initSlots();
  initSymmetry();
  initQuestions();
  initRevealed();
  initTables();
  scratch_.assign(stride_, 0);
  std::vector<std::int16_t> k0(stride_, 0);
  k0[0] = 0;
  rootIndex_ = nodeFor(k0.data(), 0);
  seconds_ = setup.seconds();  // the root's relaxation solves the sub-dialog: part of the solve
}

void CertifiedDialogSolver::Impl::applyExclusion(std::int16_t* key, int k, std::size_t v,
                                                 bool keepOnlyV) const {
  const SlotCode& c = slot_[k];
  for (std::size_t w = 0; w < c.n; ++w) {
    const bool exclude = keepOnlyV ? w != v : w == v;
    if (exclude) key[c.offset + w * c.width + c.channels] = 1;
  }
}

void CertifiedDialogSolver::Impl::canonicalize(std::int16_t* key, std::vector<std::size_t>* perm,
                                               int skipMask, bool sort) const {
  if (perm) perm->clear();
  for (int k = 0; k < kSlots; ++k) {
    const SlotCode& c = slot_[k];
    if ((skipMask >> k) & 1) {
      if (perm)
        for (std::size_t v = 0; v < c.n; ++v) perm->push_back(v);
      continue;
    }
    std::int16_t* e = key + c.offset;
    const int W = c.width;
    if (c.excl)
      for (std::size_t v = 0; v < c.n; ++v)
        if (e[v * W + c.channels])
          for (int ch = 0; ch < c.channels; ++ch) e[v * W + ch] = 0;
    for (int ch = 0; ch < c.channels; ++ch) {
      int lo = std::numeric_limits<int>::max();
      for (std::size_t v = 0; v < c.n; ++v)
        if (!c.excl || !e[v * W + c.channels]) lo = std::min(lo, static_cast<int>(e[v * W + ch]));
      if (lo == std::numeric_limits<int>::max()) continue;
      for (std::size_t v = 0; v < c.n; ++v)
        if (!c.excl || !e[v * W + c.channels]) e[v * W + ch] = static_cast<std::int16_t>(e[v * W + ch] - lo);
    }
    // Sort each class's values by their statistics (descending), remembering where each
    // canonical position came from; a class's positions (ascending) receive its values sorted.
    std::size_t order[kMaxValues];
    for (std::size_t v = 0; v < c.n; ++v) order[v] = v;
    if (W > 0 && sort && c.sortable) {
      std::int16_t copy[kMaxValues * 3];
      std::memcpy(copy, e, c.n * W * sizeof(std::int16_t));
      auto greater = [&](std::size_t x, std::size_t y) {  // statistics of x above y's
        for (int i = 0; i < W; ++i)
          if (copy[x * W + i] != copy[y * W + i]) return copy[x * W + i] > copy[y * W + i];
        return false;
      };
      for (const auto& pos : c.groups) {
        std::size_t vals[kMaxValues];
        const std::size_t m = pos.size();
        for (std::size_t j = 0; j < m; ++j) {  // insertion sort, stable
          std::size_t x = pos[j], i = j;
          while (i > 0 && greater(x, vals[i - 1])) vals[i] = vals[i - 1], --i;
          vals[i] = x;
        }
        for (std::size_t j = 0; j < m; ++j) order[pos[j]] = vals[j];
      }
      for (std::size_t v = 0; v < c.n; ++v)
        std::memcpy(e + v * W, &copy[order[v] * W], W * sizeof(std::int16_t));
    }
    if (perm) perm->insert(perm->end(), order, order + c.n);
  }
}

bool CertifiedDialogSolver::Impl::belief(const std::int16_t* key, Eigen::VectorXd& b,
                                         int fixedSlot, std::size_t fixedValue) const {
  double lam[kSlots][kMaxValues];
  std::vector<double> big;
  for (int k = 0; k < kSlots; ++k) {
    const SlotCode& c = slot_[k];
    const std::int16_t* e = key + c.offset;
    double hi = -kInf;
    double tmp[kMaxValues];
    for (std::size_t v = 0; v < c.n; ++v) {
      double l = 0.0;
      for (int ch = 0; ch < c.channels; ++ch) l += c.unit[ch] * e[v * c.width + ch];
      if (c.excl && e[v * c.width + c.channels]) l = -kInf;
      if (k == fixedSlot && v != fixedValue) l = -kInf;
      tmp[v] = l;
      hi = std::max(hi, l);
    }
    if (hi == -kInf) return false;
    for (std::size_t v = 0; v < c.n; ++v) lam[k][v] = std::exp(tmp[v] - hi);
  }
  b.resize(static_cast<Eigen::Index>(nReq_));
  double sum = 0.0;
  for (std::size_t s = 0; s < nReq_; ++s) {
    const auto& pt = parts_[s];
    const double x = root_(static_cast<Eigen::Index>(s)) * lam[0][pt[0]] * lam[1][pt[1]] * lam[2][pt[2]];
    b(static_cast<Eigen::Index>(s)) = x;
    sum += x;
  }
  if (!(sum > 0.0)) return false;
  b /= sum;
  return true;
}

void CertifiedDialogSolver::Impl::marginals(const Eigen::VectorXd& b,
                                            std::array<Eigen::VectorXd, kSlots>& m) const {
  for (int k = 0; k < kSlots; ++k) m[k].setZero(static_cast<Eigen::Index>(slot_[k].n));
  for (std::size_t s = 0; s < nReq_; ++s) {
    const double x = b(static_cast<Eigen::Index>(s));
    for (int k = 0; k < kSlots; ++k) m[k](static_cast<Eigen::Index>(parts_[s][k])) += x;
  }
}

double CertifiedDialogSolver::Impl::serveValue(const Eigen::VectorXd& b, std::size_t* best) const {
  Eigen::Index i = 0;
  const double v = (serveR_.transpose() * b).maxCoeff(&i);
  if (best) *best = static_cast<std::size_t>(i);
  return v;
}

std::size_t CertifiedDialogSolver::Impl::numAnswers(const Question& q) const {
  return q.kind == QKind::kStall ? 1 : q.kind == QKind::kAsk ? slot_[q.slot].n : 2;
}

double CertifiedDialogSolver::Impl::answerLikelihood(const Question& q, std::size_t answer,
                                                     std::size_t v) const {
  const SlotCode& c = slot_[q.slot];
  if (q.kind == QKind::kStall) return 1.0;
  if (q.kind == QKind::kAsk) {
    if (c.n == 1) return 1.0;
    return answer == v ? c.pAsk : (1.0 - c.pAsk) / (c.n - 1.0);
  }
  const bool match = v == q.value;
  return answer == 1 ? (match ? c.pConf : 1.0 - c.pConf) : (match ? 1.0 - c.pConf : c.pConf);
}

double CertifiedDialogSolver::Impl::answerProb(const Eigen::VectorXd& mk, const Question& q,
                                               std::size_t answer) const {
  if (q.kind == QKind::kStall) return 1.0;
  if (q.kind == QKind::kAsk) {
    const double x = mk(static_cast<Eigen::Index>(answer));
    return x * answerLikelihood(q, answer, answer) +
           (1.0 - x) * (slot_[q.slot].n > 1 ? answerLikelihood(q, answer, answer + 1 == slot_[q.slot].n ? 0 : answer + 1) : 0.0);
  }
  const double x = mk(static_cast<Eigen::Index>(q.value));
  return x * answerLikelihood(q, answer, q.value) +
         (1.0 - x) * answerLikelihood(q, answer, q.value + 1 == slot_[q.slot].n ? 0 : q.value + 1);
}

void CertifiedDialogSolver::Impl::childKey(const std::int16_t* key, const Question& q,
                                           std::size_t answer, std::int16_t* child) const {
  std::memcpy(child, key, stride_ * sizeof(std::int16_t));
  ++child[0];
  if (q.kind == QKind::kStall) return;
  const SlotCode& c = slot_[q.slot];
  std::int16_t* e = child + c.offset;
  if (q.kind == QKind::kAsk) {
    if (c.n == 1) return;
    for (int ch = 0; ch < c.channels; ++ch)
      e[answer * c.width + ch] = static_cast<std::int16_t>(e[answer * c.width + ch] + c.askStep[ch]);
    if (c.excl && (c.pAsk == 0.0 || c.pAsk == 1.0)) applyExclusion(child, q.slot, answer, c.pAsk == 1.0);
    return;
  }
  const int sign = answer == 1 ? 1 : -1;
  for (int ch = 0; ch < c.channels; ++ch)
    e[q.value * c.width + ch] = static_cast<std::int16_t>(e[q.value * c.width + ch] + sign * c.confStep[ch]);
  if (c.excl && (c.pConf == 0.0 || c.pConf == 1.0))
    applyExclusion(child, q.slot, q.value, (c.pConf == 1.0) == (answer == 1));
}

template <class F>
void CertifiedDialogSolver::Impl::forEachChild(const std::int16_t* key,
                                               const std::array<Eigen::VectorXd, kSlots>& m,
                                               const Question& q, F&& f) const {
  std::int16_t* child = scratch_.data();
  const std::size_t na = numAnswers(q);
  for (std::size_t ans = 0; ans < na; ++ans) {
    const std::size_t answer = q.kind == QKind::kConfirm ? 1 - ans : ans;  // yes first
    const double p = answerProb(m[q.slot], q, answer);
    if (!(p > 1e-300)) continue;
    childKey(key, q, answer, child);
    f(p, child);
  }
}

std::size_t CertifiedDialogSolver::Impl::subNode(const std::int16_t* key,
                                                const Eigen::VectorXd* hint, double* value) {
  const std::size_t found = subTable_.find(key);
  if (found != kNone) {
    *value = subValue_[found];
    return found;
  }
  const int depth = key[0];
  const SlotCode& rc = slot_[revealed_];
  const std::size_t fixed = static_cast<std::size_t>(key[rc.offset]);
  SubScratch& sc = subScratch_[static_cast<std::size_t>(depth)];
  sc.own.assign(key, key + stride_);
  // The belief: the revealed slot's statistics do not matter once its value is known.
  std::fill(sc.own.begin() + static_cast<long>(rc.offset),
            sc.own.begin() + static_cast<long>(rc.offset + rc.n * rc.width), 0);
  double v = -kInf;
  bool ok = true;
  if (hint) sc.b = *hint;
  else ok = belief(sc.own.data(), sc.b, revealed_, fixed);
  if (!subCut_ && (subTable_.size() >= maxEntries_ / 2 ||
                   (subTable_.size() % 4096 == 4095 && created_.seconds() >= o_.timeout)))
    subCut_ = true;
  if (ok && subCut_) {
    // Past its half of the memory budget, or the solver's timeout, the sub-dialog is not
    // expanded further: the full-information value (every request known, no question asked)
    // still bounds it from above, and the bounds built on it stay valid, only looser. The
    // node is not stored and has no plan (no commit lower bound through it).
    double full = 0.0;
    for (std::size_t s = 0; s < nReq_; ++s)
      full += sc.b(static_cast<Eigen::Index>(s)) * serveR_.row(static_cast<Eigen::Index>(s)).maxCoeff();
    ++subCapped_;
    *value = full;
    return kNone;
  }
  int choice = kSubServe;
  std::size_t serveA = 0;
  sc.bestKid.clear();
  sc.bestPerm.clear();
  std::fill(sc.bestT, sc.bestT + kNumPaidLevels, -kInf);
  if (ok) {
    v = serveValue(sc.b, &serveA);
    if (o_.roomPaidBound) {
      sc.kid.assign(sc.own.begin(), sc.own.end());  // free here: the children come later
      sc.kid[0] = 0;
      const auto mIns = marginTable_.insert(sc.kid.data());
      if (mIns.second) marginValue_.push_back(std::max(0.0, roomServeMargin(sc.own.data())));
      const double y = marginValue_[mIns.first];
      for (int k = 0; k < kNumPaidLevels; ++k) sc.bestT[k] = v - paidLevels_[static_cast<std::size_t>(k)] * y;
    }
    if (depth < horizon_) {
      marginals(sc.b, sc.m);
      double stallCost = kInf;  // questions on the known slot inform nothing: a stall
      double pureStall = kInf;  // a question that informs nothing at all
      int stallQ = kSubServe;
      for (std::size_t qi = 0; qi < questions_.size(); ++qi) {
        const Question& q = questions_[qi];
        if (q.kind == QKind::kStall || q.slot == revealed_) {
          if (q.cost < stallCost) stallCost = q.cost, stallQ = static_cast<int>(qi);
          if (q.kind == QKind::kStall) pureStall = std::min(pureStall, q.cost);
          continue;
        }
        const double qv = subQuestion(sc, q, fixed);
        if (o_.roomPaidBound)
          for (int k = 0; k < kNumPaidLevels; ++k)
            sc.bestT[k] = std::max(sc.bestT[k], -q.cost + gamma_ * sc.accT[k]);
        if (qv > v) {
          v = qv;
          choice = static_cast<int>(qi);
          sc.bestKid.swap(sc.kidIdx);
          sc.bestPerm.swap(sc.kidPerm);
        }
      }
      if (stallCost < kInf) {
        std::vector<std::int16_t> ck(key, key + stride_);
        ++ck[0];
        const Eigen::VectorXd same = sc.b;
        double cv;
        const std::size_t ci = subNode(ck.data(), &same, &cv);
        const double qv = -stallCost + gamma_ * cv;
        // A question about the room moves the penalty's level on (PaidStep); a true stall
        // keeps it.
        if (o_.roomPaidBound) {
          const float* tc = ci != kNone && (ci + 1) * kNumPaidLevels <= subT_.size()
                                ? &subT_[ci * kNumPaidLevels] : nullptr;
          auto childT = [&](int j) { return j < kNumPaidLevels && tc ? static_cast<double>(tc[j]) : cv; };
          if (pureStall < kInf)
            for (int k = 0; k < kNumPaidLevels; ++k)
              sc.bestT[k] = std::max(sc.bestT[k], -pureStall + gamma_ * childT(k));
          for (const PaidStep& st : paidSteps_)
            for (int k = 0; k < kNumPaidLevels; ++k)
              sc.bestT[k] = std::max(sc.bestT[k], -st.cost + gamma_ * childT(st.next[k]));
        }
        if (qv > v) {
          v = qv;
          choice = stallQ;
          sc.bestKid.assign(1, ci);
          sc.bestPerm.clear();
        }
      }
    }
  }
  const std::size_t idx = subTable_.insert(key).first;
  subValue_.push_back(v);
  subChoice_.push_back(static_cast<std::int16_t>(choice));
  if (o_.roomPaidBound && subT_.size() == idx * kNumPaidLevels) {
    for (int k = 0; k < kNumPaidLevels; ++k)
      subT_.push_back(floatUp(ok ? std::min(sc.bestT[k], v) : v));
  }
  subAlphaAt_.push_back(ok ? subPlanAlpha(sc, choice, serveA) : kNoAlpha);
  *value = v;
  return idx;
}

double CertifiedDialogSolver::Impl::subQuestion(SubScratch& sc, const Question& q,
                                                std::size_t fixed) {
  const SlotCode& rc = slot_[revealed_];
  double acc = 0.0;
  std::fill(sc.accT, sc.accT + kNumPaidLevels, 0.0);
  const std::size_t na = numAnswers(q);
  sc.kidIdx.assign(na, kNone);
  sc.kidPerm.resize(na);
  for (std::size_t answer = 0; answer < na; ++answer) {
    const double p = answerProb(sc.m[q.slot], q, answer);
    if (!(p > 1e-300)) continue;
    childKey(sc.own.data(), q, answer, sc.kid.data());
    canonicalize(sc.kid.data(), &sc.perm, 1 << revealed_);
    sc.kid[rc.offset] = static_cast<std::int16_t>(fixed);
    double cv;
    std::size_t ci = subTable_.find(sc.kid.data());
    if (ci != kNone) {
      cv = subValue_[ci];
    } else {
      childBelief(sc.b, q, answer, p, sc.cb);
      permuteBelief(sc.cb, sc.perm, sc.pb);
      const std::vector<std::int16_t> kid = sc.kid;  // the recursion reuses deeper buffers only
      ci = subNode(kid.data(), &sc.pb, &cv);
    }
    sc.kidIdx[answer] = ci;
    sc.kidPerm[answer] = sc.perm;
    acc += p * cv;
    if (o_.roomPaidBound)
      for (int k = 0; k < kNumPaidLevels; ++k)  // a child without T: V bounds it
        sc.accT[k] += p * (ci != kNone && ci * kNumPaidLevels < subT_.size()
                               ? subT_[ci * kNumPaidLevels + k] : cv);
  }
  return -q.cost + gamma_ * acc;
}

std::uint32_t CertifiedDialogSolver::Impl::subPlanAlpha(const SubScratch& at0, int choice,
                                                       std::size_t serveA) {
  // The plan's value per true request (every request, not only the known slot's: the commit
  // lower bound runs this plan when the revealed slot is not known), from the children's.
  const std::size_t n = nReq_;
  if ((subAlpha_.size() + n) * sizeof(double) > alphaBudget_) return kNoAlpha;
  std::vector<double>& alpha = alphaBuf_;
  alpha.assign(n, 0.0);
  if (choice == kSubServe) {
    for (std::size_t s = 0; s < n; ++s)
      alpha[s] = serveR_(static_cast<Eigen::Index>(s), static_cast<Eigen::Index>(serveA));
  } else {
    const Question& q = questions_[static_cast<std::size_t>(choice)];
    const bool stall = q.kind == QKind::kStall || q.slot == revealed_;
    const std::vector<std::size_t>& best = at0.bestKid;
    const std::vector<std::vector<std::size_t>>& perms = at0.bestPerm;
    std::fill(alpha.begin(), alpha.end(), -q.cost);
    if (stall) {
      const std::uint32_t at = best.empty() || best[0] == kNone ? kNoAlpha : subAlphaAt_[best[0]];
      if (at == kNoAlpha) return kNoAlpha;
      for (std::size_t s = 0; s < n; ++s) alpha[s] += gamma_ * subAlpha_[at + s];
    } else {
      for (std::size_t answer = 0; answer < best.size(); ++answer) {
        const std::uint32_t at = best[answer] == kNone ? kNoAlpha : subAlphaAt_[best[answer]];
        if (at == kNoAlpha) return kNoAlpha;  // a child cut off, or an answer not followed
        const std::vector<std::size_t>& perm = perms[answer];
        const std::size_t o1 = slot_[0].n, o2 = o1 + slot_[1].n;
        for (std::size_t c = 0; c < n; ++c) {  // child's canonical request c -> this node's s
          const auto& pt = parts_[c];
          const std::size_t s = d_.requestIndex(perm[pt[0]], perm[o1 + pt[1]], perm[o2 + pt[2]]);
          alpha[s] += gamma_ * answerLikelihood(q, answer, parts_[s][q.slot]) * subAlpha_[at + c];
        }
      }
    }
  }
  const std::uint32_t at = static_cast<std::uint32_t>(subAlpha_.size());
  subAlpha_.insert(subAlpha_.end(), alpha.begin(), alpha.end());
  return at;
}

double CertifiedDialogSolver::Impl::roomServeMargin(const std::int16_t* ownZeroed) const {
  // The belief with the room's likelihoods all 1: b|r of every room at these statistics.
  Eigen::VectorXd b;
  if (!belief(ownZeroed, b)) return -kInf;
  const std::size_t m = slot_[revealed_].n;
  double mass[kMaxValues] = {0.0};
  for (std::size_t s = 0; s < nReq_; ++s) mass[parts_[s][revealed_]] += b(static_cast<Eigen::Index>(s));
  // acc(r, a) = sum_{s in r} b(s) R(s, a); the room-known serve at r is max_a acc(r, a) / mass_r
  Eigen::MatrixXd& acc = marginScratch_;
  acc.setZero(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(nReq_));
  for (std::size_t s = 0; s < nReq_; ++s) {
    const double x = b(static_cast<Eigen::Index>(s));
    if (x > 0.0) acc.row(static_cast<Eigen::Index>(parts_[s][revealed_])) += x * serveR_.row(static_cast<Eigen::Index>(s));
  }
  double y = kInf;
  for (std::size_t r = 0; r < m; ++r) {
    if (!(mass[r] > 0.0)) continue;
    const double serve = acc.row(static_cast<Eigen::Index>(r)).maxCoeff() / mass[r];
    for (std::size_t r2 = 0; r2 < m; ++r2)
      if (r2 != r) y = std::min(y, serve - wrongRoom_[r * m + r2]);
  }
  return y == kInf ? -kInf : y;
}

double CertifiedDialogSolver::Impl::lookaheadValue(const Eigen::VectorXd& b,
                                                   const double* const* A, std::size_t* bestLook,
                                                   std::vector<std::size_t>* bestRoom) const {
  // P(r, r') = sum over requests s in room r' of A_r(s) b(s): an answer's likelihood depends
  // on the room only, so plan r's value after answer o is sum_r' P(r, r') lik_o(r').
  const std::size_t m = slot_[revealed_].n;
  double P[kMaxValues * kMaxValues];
  bool any = false;
  for (std::size_t r = 0; r < m; ++r) {
    double* row = P + r * m;
    std::fill(row, row + m, 0.0);
    if (!A[r]) continue;
    any = true;
    for (std::size_t s = 0; s < nReq_; ++s)
      row[parts_[s][revealed_]] += A[r][s] * b(static_cast<Eigen::Index>(s));
  }
  double best = -kInf;
  if (!any) return best;
  std::vector<std::size_t> rooms;
  for (std::size_t li = 0; li < roomLooks_.size(); ++li) {
    const RoomLook& L = roomLooks_[li];
    double tot = 0.0;
    rooms.assign(L.answers, 0);
    for (std::size_t o = 0; o < L.answers; ++o) {
      const double* lik = &L.lik[o * m];
      double hi = -kInf;
      for (std::size_t r = 0; r < m; ++r) {
        if (!A[r]) continue;
        double x = 0.0;
        for (std::size_t r2 = 0; r2 < m; ++r2) x += P[r * m + r2] * lik[r2];
        if (x > hi) hi = x, rooms[o] = r;
      }
      tot += hi;
    }
    const double v = -questions_[L.qi].cost + gamma_ * tot;
    if (v > best) {
      best = v;
      if (bestLook) *bestLook = li;
      if (bestRoom) *bestRoom = rooms;
    }
  }
  return best;
}

void CertifiedDialogSolver::Impl::initPaidLevels(std::size_t m) {
  paidLevels_.resize(kNumPaidLevels);
  // theta >= 1/m: odds from 1/(m - 1) up (one value: no penalty at all).
  const double low = m > 1 ? -std::log2(static_cast<double>(m - 1)) : kInf;
  for (int k = 0; k < kNumPaidLevels; ++k)
    paidLevels_[static_cast<std::size_t>(k)] =
        1.0 / (1.0 + std::exp2(low + static_cast<double>(k) / kPaidPerDoubling));
  paidSteps_.clear();
  for (const RoomLook& L : roomLooks_) {
    // G: the largest ratio of one answer's likelihoods over the rooms (infinite when an
    // answer excludes a room: the level then drops to none).
    double g = 1.0;
    for (std::size_t o = 0; o < L.answers; ++o) {
      const double* lik = &L.lik[o * m];
      const double hi = *std::max_element(lik, lik + m), lo = *std::min_element(lik, lik + m);
      if (hi > 0.0) g = std::max(g, lo > 0.0 ? hi / lo : kInf);
    }
    const double cost = questions_[L.qi].cost;
    bool seen = false;
    for (const PaidStep& st : paidSteps_) seen = seen || (st.cost <= cost && st.ratio >= g);
    if (seen) continue;
    PaidStep st{cost, g, {}};
    // theta' / (1 - theta') <= G theta / (1 - theta): the odds move up log2 G doublings,
    // rounded down to whole steps (a smaller penalty: the relaxation only gains); past the
    // grid, no penalty (kNumPaidLevels).
    const double steps = g == kInf ? kNumPaidLevels : std::floor(std::log2(g) * kPaidPerDoubling);
    for (int k = 0; k < kNumPaidLevels; ++k)
      st.next[k] = static_cast<int>(std::min<double>(kNumPaidLevels, k + steps));
    paidSteps_.push_back(st);
  }
}

double CertifiedDialogSolver::Impl::roomCeiling(const Eigen::VectorXd& b) const {
  double theta = 0.0;
  for (const auto& g : otherGroups_) {
    double sum = 0.0, hi = 0.0;
    for (const std::size_t s : g) {
      const double x = b(static_cast<Eigen::Index>(s));
      sum += x;
      hi = std::max(hi, x);
    }
    if (sum > 0.0) theta = std::max(theta, hi / sum);
  }
  return std::min(theta, 1.0);
}

double CertifiedDialogSolver::Impl::upperRelaxation(const std::int16_t* key,
                                                    const Eigen::VectorXd& b,
                                                    double* commitLower, std::uint32_t* group) {
  const SlotCode& rc = slot_[revealed_];
  Eigen::VectorXd mr = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(rc.n));
  for (std::size_t s = 0; s < nReq_; ++s) mr(static_cast<Eigen::Index>(parts_[s][revealed_])) += b(static_cast<Eigen::Index>(s));
  std::vector<std::int16_t>& sub = subMemo_.scratch;
  sub.assign(key, key + stride_);
  std::fill(sub.begin() + static_cast<long>(rc.offset),
            sub.begin() + static_cast<long>(rc.offset + rc.n * rc.width), 0);
  // The children of a question about the room share their other slots and turn: their
  // sub-dialog nodes are looked up once.
  if (sub != subMemo_.key) {
    subMemo_.key = sub;
    std::fill(subMemo_.at, subMemo_.at + 2 * kMaxValues, kUnknownSub);
    subMemo_.group = kNoGroup;
  }
  auto subIndex = [&](int later, std::size_t r, double* v) {
    std::size_t& at = subMemo_.at[later * kMaxValues + r];
    if (at != kUnknownSub) {
      *v = subValue_[at];
      return at;
    }
    sub[rc.offset] = static_cast<std::int16_t>(r);
    sub[0] = static_cast<std::int16_t>(key[0] + later);
    const std::size_t i = subNode(sub.data(), nullptr, v);
    sub[0] = key[0];
    if (i != kNone) at = i;  // a cut-off node has no index (its value is computed)
    return i;
  };
  double u = 0.0, commit = -kInf;
  // The room paid for: the largest level whose penalty 1 - theta allows (kNumPaidLevels: none).
  int level = kNumPaidLevels;
  if (o_.roomPaidBound) {
    const double slack = 1.0 - roomCeiling(b);
    for (int k = 0; k < kNumPaidLevels && level == kNumPaidLevels; ++k)
      if (paidLevels_[static_cast<std::size_t>(k)] <= slack) level = k;
  }
  double paid = 0.0;
  for (std::size_t r = 0; r < rc.n; ++r) {
    const double w = mr(static_cast<Eigen::Index>(r));
    if (!(w > 0.0)) continue;
    double v;
    const std::size_t i = subIndex(0, r, &v);
    u += w * v;
    paid += w * (level < kNumPaidLevels && i != kNone && (i + 1) * kNumPaidLevels <= subT_.size()
                     ? subT_[i * kNumPaidLevels + level] : v);
    // Commit to r: run r's sub-dialog plan, whatever the true value (a plan the robot can
    // run; its vector is exact for every request, the sub-key's order is this key's).
    if (commitLower && i != kNone && subAlphaAt_[i] != kNoAlpha) {
      const double* a = &subAlpha_[subAlphaAt_[i]];
      double c = 0.0;
      for (std::size_t s = 0; s < nReq_; ++s) c += a[s] * b(static_cast<Eigen::Index>(s));
      commit = std::max(commit, c);
    }
  }
  u = std::min(u, paid);
  if (commitLower && o_.roomLookahead && !roomLooks_.empty()) {
    // Ask about the room once, then commit (valued at the next turn's plans).
    const double* A[kMaxValues];
    bool all = true;
    for (std::size_t r = 0; r < rc.n && all; ++r) {
      A[r] = nullptr;
      if (!(mr(static_cast<Eigen::Index>(r)) > 0.0)) continue;
      double v;
      const std::size_t i = subIndex(1, r, &v);
      if (i == kNone || subAlphaAt_[i] == kNoAlpha) all = false;
      else A[r] = &subAlpha_[subAlphaAt_[i]];
    }
    if (all) commit = std::max(commit, lookaheadValue(b, A, nullptr, nullptr));
  }
  if (commitLower) *commitLower = commit;
  if (group) {
    if (subMemo_.group == kNoGroup) {
      sub[rc.offset] = 0;
      subMemo_.group = static_cast<std::uint32_t>(groupTable_.insert(sub.data()).first);
    }
    *group = subMemo_.group;
  }
  return u;
}

std::vector<double>& CertifiedDialogSolver::Impl::groupDataOf(std::size_t n) {
  const auto found = groupData_.find(nodes_[n].group);
  if (found != groupData_.end()) return found->second;
  // The corners of n's simplex: every room's value, also those of rooms n excludes (other
  // nodes of the simplex may not).
  const SlotCode& rc = slot_[revealed_];
  std::vector<std::int16_t> sub(table_.key(n), table_.key(n) + stride_);
  std::fill(sub.begin() + static_cast<long>(rc.offset),
            sub.begin() + static_cast<long>(rc.offset + rc.n * rc.width), 0);
  std::vector<double> data(2 * rc.n, kInf);
  Eigen::VectorXd b0;
  const bool ok = belief(sub.data(), b0);
  for (std::size_t r = 0; r < rc.n; ++r) {
    double z = 0.0;
    if (ok)
      for (std::size_t s = 0; s < nReq_; ++s)
        if (parts_[s][revealed_] == r) z += b0(static_cast<Eigen::Index>(s));
    data[r] = z;
    sub[rc.offset] = static_cast<std::int16_t>(r);
    if (z > 0.0) subNode(sub.data(), nullptr, &data[rc.n + r]);
  }
  groupDataBytes_ += data.capacity() * sizeof(double) + 64;
  return groupData_.emplace(nodes_[n].group, std::move(data)).first->second;
}

double CertifiedDialogSolver::Impl::simplexWeights(const std::int16_t* key,
                                                   const std::vector<double>& data,
                                                   double* w) const {
  const SlotCode& rc = slot_[revealed_];
  const double* Z = data.data();
  const double* V = Z + rc.n;
  const std::int16_t* e = key + rc.offset;
  double l[kMaxValues], hi = -kInf;
  for (std::size_t r = 0; r < rc.n; ++r) {
    double x = 0.0;
    for (int ch = 0; ch < rc.channels; ++ch) x += rc.unit[ch] * e[r * rc.width + ch];
    if (rc.excl && e[r * rc.width + rc.channels]) x = -kInf;
    if (!(Z[r] > 0.0)) x = -kInf;
    l[r] = x;
    hi = std::max(hi, x);
  }
  double sum = 0.0;
  for (std::size_t r = 0; r < rc.n; ++r) {
    w[r] = l[r] == -kInf ? 0.0 : Z[r] * std::exp(l[r] - hi);
    sum += w[r];
  }
  double line = 0.0;
  for (std::size_t r = 0; r < rc.n; ++r) {
    w[r] /= sum;
    if (w[r] > 0.0) line += w[r] * V[r];
  }
  return line;
}

double CertifiedDialogSolver::Impl::effUpper(std::size_t n) const {
  const Node& nd = nodes_[n];
  return sharedUpper(table_.key(n), nd.upper, nd.group, nd.head, n);
}

double CertifiedDialogSolver::Impl::sharedUpper(const std::int16_t* key, double upper,
                                                std::uint32_t group, std::uint32_t head,
                                                std::size_t self) const {
  const double own = head == kNoHead ? upper : std::min(upper, nodes_[head].upper);
  if (group == kNoGroup) return own;
  const auto found = groupData_.find(group);
  if (found == groupData_.end()) return own;
  const std::vector<double>& pts = found->second;
  const std::size_t m = slot_[revealed_].n, width = m + 2;
  if (pts.size() <= 2 * m) return own;  // corners known, no point yet
  double w[kMaxValues];
  const double line = simplexWeights(key, pts, w);
  double cut = 0.0;
  for (std::size_t j = 2 * m; j + width <= pts.size(); j += width) {
    if (static_cast<std::size_t>(pts[j]) == self) continue;
    double rho = kInf;
    for (std::size_t r = 0; r < m && rho > 0.0; ++r)
      if (pts[j + 2 + r] > 0.0) rho = std::min(rho, w[r] / pts[j + 2 + r]);
    if (rho < kInf) cut = std::max(cut, rho * pts[j + 1]);
  }
  return std::min(own, line - cut);
}

void CertifiedDialogSolver::Impl::notePoint(std::size_t n) {
  const Node& nd = nodes_[n];
  if (nd.group == kNoGroup) return;
  const std::size_t m = slot_[revealed_].n, width = m + 2;
  double w[kMaxValues];
  std::vector<double>& pts = groupDataOf(n);
  const double delta = simplexWeights(table_.key(n), pts, w) - nd.upper;
  if (!(delta > 1e-9)) return;
  const std::size_t before = pts.capacity();
  std::size_t at = pts.size(), weakest = pts.size();
  for (std::size_t j = 2 * m; j + width <= pts.size(); j += width) {
    if (static_cast<std::size_t>(pts[j]) == n) { at = j; break; }
    if (weakest == pts.size() || pts[j + 1] < pts[weakest + 1]) weakest = j;
  }
  if (at == pts.size()) {
    if (pts.size() < 2 * m + kSimplexPoints * width) pts.resize(pts.size() + width);
    else if (pts[weakest + 1] < delta) at = weakest;
    else return;
  }
  pts[at] = static_cast<double>(n);
  pts[at + 1] = delta;
  for (std::size_t r = 0; r < m; ++r) pts[at + 2 + r] = w[r];
  groupDataBytes_ += (pts.capacity() - before) * sizeof(double);
}

void CertifiedDialogSolver::Impl::childBelief(const Eigen::VectorXd& b, const Question& q,
                                              std::size_t answer, double p,
                                              Eigen::VectorXd& out) const {
  out.resize(b.size());
  const double inv = 1.0 / p;
  for (std::size_t s = 0; s < nReq_; ++s)
    out(static_cast<Eigen::Index>(s)) = b(static_cast<Eigen::Index>(s)) * inv *
                                        answerLikelihood(q, answer, parts_[s][q.slot]);
}

void CertifiedDialogSolver::Impl::permuteBelief(const Eigen::VectorXd& in,
                                                const std::vector<std::size_t>& perm,
                                                Eigen::VectorXd& out) const {
  out.resize(in.size());
  const std::size_t o1 = slot_[0].n, o2 = o1 + slot_[1].n;
  for (std::size_t s = 0; s < nReq_; ++s) {
    const auto& pt = parts_[s];
    out(static_cast<Eigen::Index>(s)) =
        in(static_cast<Eigen::Index>(d_.requestIndex(perm[pt[0]], perm[o1 + pt[1]], perm[o2 + pt[2]])));
  }
}

std::size_t CertifiedDialogSolver::Impl::nodeFor(const std::int16_t* key, int depth,
                                                 const Eigen::VectorXd* hint) {
  const std::size_t found = table_.find(key);
  if (found != kNone) return found;
  double upper, lower;
  std::uint32_t group, head;
  newBounds(key, depth, hint, upper, lower, group, head);
  const std::size_t n = table_.insert(key).first;
  if (head == kNoHead) head = static_cast<std::uint32_t>(n);
  nodes_.push_back({upper, lower, group, head});
  expandedFlags_.push_back(false);
  slotChunk_.push_back(0);
  slotAt_.push_back(0);
  if (group != kNoGroup || head != n) {
    const double cut = effUpper(n);
    if (cut < nodes_[n].upper) ++sharedCuts_;
    nodes_[n].upper = uncrossed(cut, lower);
  }
  return n;
}

void CertifiedDialogSolver::Impl::newBounds(const std::int16_t* key, int depth,
                                            const Eigen::VectorXd* hint, double& upper,
                                            double& lower, std::uint32_t& group,
                                            std::uint32_t& head) {
  Eigen::VectorXd own;
  if (!hint) {
    if (!belief(key, own)) throw ConfigError("certified dialog solver: a reachable belief is empty");
    hint = &own;
  }
  const Eigen::VectorXd& b = *hint;
  const double serve = serveValue(b);
  upper = serve;
  lower = serve;
  group = kNoGroup;
  if (depth < horizon_) {
    double commit = -kInf;
    upper = std::max(serve, upperRelaxation(key, b, o_.commitLower ? &commit : nullptr,
                                            o_.shareUpperBounds ? &group : nullptr));
    lower = std::max(lower, commit);  // a plan the robot can run
    upper = uncrossed(upper, lower);
  }
  // The same statistics reached in fewer turns: share its upper bound (never the other way).
  head = kNoHead;
  if (o_.shareUpperBounds) {
    statsScratch_.assign(key, key + stride_);
    statsScratch_[0] = 0;
    const std::size_t at = statsTable_.find(statsScratch_.data());
    if (at != kNone && table_.key(statsNode_[at])[0] <= depth) head = statsNode_[at];
  }
}

CertifiedDialogSolver::Impl::Backup CertifiedDialogSolver::Impl::backup(std::size_t n) {
  Backup r;
  std::vector<std::int16_t> key(table_.key(n), table_.key(n) + stride_);
  const int depth = key[0];
  Eigen::VectorXd b;
  belief(key.data(), b);
  const double serve = serveValue(b);
  kidProb_.clear();
  kidNode_.clear();
  kidUpper_.clear();
  kidLower_.clear();
  kidAnswer_.clear();
  kidPos_.clear();
  kidStart_.assign(1, 0);
  if (depth >= horizon_) {
    nodes_[n].upper = nodes_[n].lower = serve;
    return r;
  }
  std::array<Eigen::VectorXd, kSlots> m;
  marginals(b, m);
  double bestU = serve, bestL = serve;
  // Slots (see leafCache_): read them once expanded; made at the first expansion.
  const bool makeSlots = leafCache_ && !expandedFlags_[n];
  std::uint32_t* slots = leafCache_ && expandedFlags_[n] ? slotsOf(n) : nullptr;
  if (makeSlots) freshSlots_.assign(2 * numPos_, 0);
  for (std::size_t qi = 0; qi < questions_.size(); ++qi) {
    const Question& q = questions_[qi];
    double qu = 0.0, ql = 0.0;
    for (std::size_t answer = 0; answer < numAnswers(q); ++answer) {
      const double p = answerProb(m[q.slot], q, answer);
      if (!(p > 1e-300)) continue;
      const std::size_t pos = posOf_.empty() ? 0 : posOf_[qi] + answer;
      double cu = 0.0, cl = 0.0;
      const std::size_t c = childBounds(key.data(), b, q, answer, p, pos, slots, makeSlots, cu, cl);
      qu += p * cu;
      ql += p * cl;
      kidProb_.push_back(p);
      kidNode_.push_back(c);
      kidUpper_.push_back(cu);
      kidLower_.push_back(cl);
      kidAnswer_.push_back(answer);
      kidPos_.push_back(pos);
    }
    kidStart_.push_back(kidNode_.size());
    qu = -q.cost + gamma_ * qu;
    ql = -q.cost + gamma_ * ql;
    if (qu > bestU) bestU = qu, r.bestUpper = qi;
    if (ql > bestL) bestL = ql, r.bestLower = qi;
  }
  if (makeSlots) {
    if (slotUsed_ + freshSlots_.size() > kSlotChunkWords) {
      slotChunks_.emplace_back(new std::uint32_t[kSlotChunkWords]);
      slotUsed_ = 0;
    }
    slotChunk_[n] = static_cast<std::uint32_t>(slotChunks_.size() - 1);
    slotAt_[n] = static_cast<std::uint32_t>(slotUsed_);
    std::copy(freshSlots_.begin(), freshSlots_.end(), &slotChunks_.back()[slotUsed_]);
    slotUsed_ += freshSlots_.size();
  }
  Node& nd = nodes_[n];
  if (!expandedFlags_[n]) {
    ++expanded_;
    expandedFlags_[n] = true;
    if (o_.shareUpperBounds) {  // register n as its statistics' head if it is the shallowest
      statsScratch_.assign(key.begin(), key.end());
      statsScratch_[0] = 0;
      const auto sIns = statsTable_.insert(statsScratch_.data());
      if (sIns.second) statsNode_.push_back(static_cast<std::uint32_t>(n));
      else if (table_.key(statsNode_[sIns.first])[0] > depth)
        statsNode_[sIns.first] = static_cast<std::uint32_t>(n);
    }
  }
  nd.upper = std::min(nd.upper, bestU);
  nd.lower = std::max(nd.lower, bestL);
  nd.upper = std::min(nd.upper, effUpper(n));
  nd.upper = uncrossed(nd.upper, nd.lower);
  notePoint(n);
  return r;
}

std::size_t CertifiedDialogSolver::Impl::childBounds(const std::int16_t* key,
                                                    const Eigen::VectorXd& b, const Question& q,
                                                    std::size_t answer, double p, std::size_t pos,
                                                    std::uint32_t* slots, bool makeSlots,
                                                    double& cu, double& cl) {
  std::size_t c = kNone;
  std::vector<std::int16_t>& kid = childScratch_.key;
  std::vector<std::size_t>& perm = childScratch_.perm;
  Eigen::VectorXd& cb = childScratch_.cb;
  Eigen::VectorXd& pb = childScratch_.pb;
  kid.resize(stride_);
  const int depth = key[0];
  if (slots && slots[2 * pos + 1] == kLinked) {
    c = slots[2 * pos];
  } else if (slots) {
    // Another parent may have made it a node since (the same statistics by another
    // order of questions): link it, its bounds only get better.
    childKey(key, q, answer, kid.data());
    canonicalize(kid.data());
    c = table_.find(kid.data());
    if (c != kNone) {
      slots[2 * pos] = static_cast<std::uint32_t>(c);
      slots[2 * pos + 1] = kLinked;
    } else {
      unpackSlot(slots + 2 * pos, cu, cl);
    }
  } else {
    childKey(key, q, answer, kid.data());
    canonicalize(kid.data(), &perm);
    c = table_.find(kid.data());
    if (c == kNone) {
      childBelief(b, q, answer, p, cb);
      permuteBelief(cb, perm, pb);
      if (makeSlots) {
        double u, l;
        std::uint32_t g, h;
        newBounds(kid.data(), depth + 1, &pb, u, l, g, h);
        // the shared bounds as they are now (a kept child's bound is not revisited)
        packSlot(uncrossed(sharedUpper(kid.data(), u, g, h, kNone), l), l, &freshSlots_[2 * pos]);
        unpackSlot(&freshSlots_[2 * pos], cu, cl);
      } else {
        c = nodeFor(kid.data(), depth + 1, &pb);
      }
    } else if (makeSlots) {
      freshSlots_[2 * pos] = static_cast<std::uint32_t>(c);
      freshSlots_[2 * pos + 1] = kLinked;
    }
  }
  if (c != kNone) {
    cl = nodes_[c].lower;
    cu = uncrossed(effUpper(c), cl);
  }
  return c;
}

void CertifiedDialogSolver::Impl::packSlot(double upper, double lower, std::uint32_t* w) {
  float fu = static_cast<float>(upper), fl = static_cast<float>(lower);
  if (static_cast<double>(fu) < upper) fu = std::nextafter(fu, std::numeric_limits<float>::infinity());
  if (static_cast<double>(fl) > lower) fl = std::nextafter(fl, -std::numeric_limits<float>::infinity());
  std::memcpy(&w[0], &fu, sizeof(float));
  std::memcpy(&w[1], &fl, sizeof(float));
}

void CertifiedDialogSolver::Impl::trial() {
  // HSVI's trial precision: a fraction of the target gap at the root (trialTarget), grown by
  // 1 / discount per level.
  double thr = o_.precision * o_.trialTarget;
  std::vector<std::size_t> path{rootIndex_};
  std::vector<std::pair<double, std::size_t>> cand;
  const bool lowerGuided = o_.lowerGuidedEvery > 0 && trials_ % o_.lowerGuidedEvery == 1;
  for (int depth = 0; depth < horizon_; ++depth) {
    const std::size_t n = path.back();
    const Backup bk = backup(n);
    const std::size_t act = lowerGuided ? bk.bestLower : bk.bestUpper;
    if (nodes_[n].upper - nodes_[n].lower <= thr || act == kNone) break;
    thr /= gamma_;
    // The chosen question's children, as backup() just read them (sampled in forEachChild's
    // order: yes before no).
    cand.clear();
    double total = 0.0;
    const bool yesFirst = questions_[act].kind == QKind::kConfirm;
    for (std::size_t j = kidStart_[act]; j < kidStart_[act + 1]; ++j) {
      const std::size_t i = yesFirst ? kidStart_[act + 1] - 1 - (j - kidStart_[act]) : j;
      const double gap = kidUpper_[i] - kidLower_[i];
      // HSVI's excess uncertainty, sampled (following the largest one stalls on this model)
      cand.push_back({gap > thr ? kidProb_[i] * (gap - thr) : 0.0, i});
      total += cand.back().first;
    }
    if (!(total > 0.0)) break;
    double u = uniform01(rng_) * total;
    std::size_t pick = cand.size() - 1;
    for (std::size_t i = 0; i < cand.size(); ++i) {
      if (cand[i].first <= 0.0) continue;
      pick = i;
      if (u < cand[i].first) break;
      u -= cand[i].first;
    }
    const std::size_t i = cand[pick].second;
    std::size_t c = kidNode_[i];
    if (c == kNone) {  // a kept child: the trial enters it, so it becomes a node, linked here
      std::vector<std::int16_t> kid(stride_);
      childKey(table_.key(n), questions_[act], kidAnswer_[i], kid.data());
      canonicalize(kid.data());
      c = nodeFor(kid.data(), depth + 1);
      std::uint32_t* w = slotsOf(n) + 2 * kidPos_[i];
      w[0] = static_cast<std::uint32_t>(c);
      w[1] = kLinked;
    }
    path.push_back(c);
  }
  for (auto it = path.rbegin(); it != path.rend(); ++it) backup(*it);
  ++trials_;
}


std::size_t CertifiedDialogSolver::Impl::bytes() const {
  return table_.bytes() + subTable_.bytes() + groupTable_.bytes() + groupDataBytes_ +
         groupData_.bucket_count() * sizeof(void*) + statsTable_.bytes() +
         statsNode_.capacity() * sizeof(std::uint32_t) +
         (nodesReserved_ ? nodes_.size() : nodes_.capacity()) * sizeof(Node) +
         expandedFlags_.capacity() / 8 +
         slotChunks_.size() * kSlotChunkWords * sizeof(std::uint32_t) +
         (slotChunk_.capacity() + slotAt_.capacity()) * sizeof(std::uint32_t) +
         subValue_.capacity() * sizeof(double) + subChoice_.capacity() * sizeof(std::int16_t) +
         subT_.capacity() * sizeof(float) + marginTable_.bytes() +
         marginValue_.capacity() * sizeof(double) +
         subAlphaAt_.capacity() * sizeof(std::uint32_t) + subAlpha_.capacity() * sizeof(double);
}

bool CertifiedDialogSolver::Impl::memoryExceeded() const {
  return bytes() > tableBudget_ || table_.size() + subTable_.size() > maxEntries_;
}

bool CertifiedDialogSolver::Impl::run(std::size_t maxMore) {
  Stopwatch clock;
  const double before = seconds_;
  std::size_t ran = 0;
  stop_ = SolveStop::kRunning;
  for (;;) {
    const Node& rt = nodes_[rootIndex_];
    if (rt.upper - rt.lower <= o_.precision) { stop_ = SolveStop::kPrecision; break; }
    if (o_.maxTrials > 0 && trials_ >= o_.maxTrials) { stop_ = SolveStop::kTrials; break; }
    if (ran >= maxMore) break;
    if (before + clock.seconds() >= o_.timeout) { stop_ = SolveStop::kTimeout; break; }
    if (memoryExceeded()) { stop_ = SolveStop::kMemory; break; }
    trial();
    ++ran;
  }
  seconds_ = before + clock.seconds();
  return stop_ == SolveStop::kPrecision;
}

double CertifiedDialogSolver::Impl::exactValue(std::int16_t* key, int depth,
                                               std::unordered_map<std::string, double>& memo,
                                               std::size_t maxNodes) {
  const std::string k(reinterpret_cast<const char*>(key), stride_ * sizeof(std::int16_t));
  const auto it = memo.find(k);
  if (it != memo.end()) return it->second;
  if (memo.size() >= maxNodes)
    throw ConfigError("certified dialog solver: exact value needs more than " +
                      std::to_string(maxNodes) + " nodes");
  Eigen::VectorXd b;
  belief(key, b);
  double v = serveValue(b);
  if (depth < horizon_) {
    std::array<Eigen::VectorXd, kSlots> m;
    marginals(b, m);
    for (const Question& q : questions_) {
      std::vector<std::pair<double, std::vector<std::int16_t>>> kids;
      forEachChild(key, m, q, [&](double p, const std::int16_t* ck) {
        kids.emplace_back(p, std::vector<std::int16_t>(ck, ck + stride_));
      });
      double acc = 0.0;
      for (auto& kid : kids) {
        canonicalize(kid.second.data());
        acc += kid.first * exactValue(kid.second.data(), depth + 1, memo, maxNodes);
      }
      v = std::max(v, -q.cost + gamma_ * acc);
    }
  }
  memo.emplace(k, v);
  return v;
}

std::size_t CertifiedDialogSolver::Impl::lowerChoice(const std::int16_t* ck) const {
  const std::size_t n = table_.find(ck);
  const int depth = ck[0];
  if (n == kNone || !expandedFlags_[n] || depth >= horizon_) return kNone;
  Eigen::VectorXd b;
  belief(ck, b);
  const double serve = serveValue(b);
  std::array<Eigen::VectorXd, kSlots> m;
  marginals(b, m);
  std::size_t best = kNone;
  double bestL = serve + 1e-9 * (1.0 + std::abs(serve));
  std::vector<std::int16_t> kid(stride_);
  const std::uint32_t* slots = leafCache_ ? slotsOf(n) : nullptr;
  for (std::size_t qi = 0; qi < questions_.size(); ++qi) {
    const Question& q = questions_[qi];
    double ql = 0.0;
    bool complete = true;
    for (std::size_t answer = 0; answer < numAnswers(q) && complete; ++answer) {
      const double p = answerProb(m[q.slot], q, answer);
      if (!(p > 1e-300)) continue;
      if (slots) {
        const std::uint32_t* w = slots + 2 * (posOf_[qi] + answer);
        double u, l;
        if (w[1] == kLinked) l = nodes_[w[0]].lower;
        else unpackSlot(w, u, l);
        ql += p * l;
        continue;
      }
      childKey(ck, q, answer, kid.data());
      canonicalize(kid.data());
      const std::size_t ci = table_.find(kid.data());
      if (ci != kNone) ql += p * nodes_[ci].lower;
      else complete = false;
    }
    if (!complete) continue;
    ql = -q.cost + gamma_ * ql;
    if (ql > bestL) bestL = ql, best = qi;
  }
  return best;
}

Question CertifiedDialogSolver::Impl::actualQuestion(
    std::size_t choice, const std::vector<std::size_t>& perm) const {
  Question q = questions_[choice];
  if (q.kind == QKind::kConfirm) {
    std::size_t off = 0;
    for (int k = 0; k < q.slot; ++k) off += slot_[k].n;
    q.value = perm[off + q.value];
    q.action = q.slot == 0 ? d_.confirmItem(q.value)
                           : q.slot == 1 ? d_.confirmRoom(q.value) : d_.confirmPerson(q.value);
  }
  return q;
}

std::unordered_map<std::string, double> CertifiedDialogSolver::Impl::policyReach(double floor) const {
  std::unordered_map<std::string, double> reach;
  std::vector<std::vector<std::string>> layers(static_cast<std::size_t>(horizon_) + 1);
  const std::string k0(stride_ * sizeof(std::int16_t), '\0');
  reach[k0] = 1.0;
  layers[0].push_back(k0);
  std::vector<std::int16_t> key(stride_), canon(stride_), kid(stride_);
  std::vector<std::size_t> perm;
  Eigen::VectorXd b;
  std::array<Eigen::VectorXd, kSlots> m;
  for (int d = 0; d < horizon_; ++d)
    for (const std::string& k : layers[static_cast<std::size_t>(d)]) {
      const double r = reach[k];
      if (r < floor) continue;
      std::memcpy(key.data(), k.data(), k.size());
      canon = key;
      canonicalize(canon.data(), &perm);
      const std::size_t choice = lowerChoice(canon.data());
      if (choice == kNone) continue;
      const Question q = actualQuestion(choice, perm);
      belief(key.data(), b);
      marginals(b, m);
      for (std::size_t answer = 0; answer < numAnswers(q); ++answer) {
        const double p = answerProb(m[q.slot], q, answer);
        if (!(p > 1e-300)) continue;
        childKey(key.data(), q, answer, kid.data());
        canonicalize(kid.data(), nullptr, 0, false);
        const std::string ck(reinterpret_cast<const char*>(kid.data()), k.size());
        const auto ins = reach.emplace(ck, 0.0);
        if (ins.second) layers[static_cast<std::size_t>(d) + 1].push_back(ck);
        ins.first->second += r * p;
      }
    }
  return reach;
}

std::size_t CertifiedDialogSolver::Impl::planVector(
    const std::int16_t* key, const std::unordered_map<std::string, double>& reach, double floor,
    PlanExport& ex) const {
  const std::string mk(reinterpret_cast<const char*>(key), stride_ * sizeof(std::int16_t));
  const auto it = ex.memo.find(mk);
  if (it != ex.memo.end()) return it->second;

  const int depth = key[0];
  std::vector<std::int16_t> canon(key, key + stride_);
  std::vector<std::size_t> perm;
  canonicalize(canon.data(), &perm);
  std::size_t choice = lowerChoice(canon.data());
  const auto rit = reach.find(mk);
  const bool truncated = rit == reach.end() || rit->second < floor;
  // Rarely reached: its plan is the frontier's below (its commit plan, whose value the
  // search's lower bound counts at unexpanded nodes, rather than serving at once).
  if (truncated) choice = kNone;
  Eigen::VectorXd b;
  belief(key, b);
  std::size_t serveA = 0;
  serveValue(b, &serveA);
  Eigen::VectorXd alpha(static_cast<Eigen::Index>(nReq_));
  std::size_t action;
  alpha = serveR_.col(static_cast<Eigen::Index>(serveA));  // serve now
  action = d_.serveAction(serveA);
  std::vector<long> next(ex.obs, -1);
  if (choice == kNone) {
    if (o_.commitLower && depth < horizon_)
      frontierPlan(key, b, truncated ? 0.0 : rit->second, alpha, action, next, ex);
  } else {
    const Question q = actualQuestion(choice, perm);
    action = q.action;
    std::array<Eigen::VectorXd, kSlots> m;
    marginals(b, m);
    alpha.setConstant(-q.cost);
    std::vector<std::int16_t> kid(stride_);
    for (std::size_t answer = 0; answer < numAnswers(q); ++answer) {
      childKey(key, q, answer, kid.data());
      canonicalize(kid.data(), nullptr, 0, false);
      long cont;
      if (answerProb(m[q.slot], q, answer) > 1e-300) {
        const std::size_t ci = planVector(kid.data(), reach, floor, ex);
        cont = static_cast<long>(ci);
        addAnswer(alpha, q, answer, ex.vectors[ci]);
      } else {  // unreachable here: serve
        cont = kServeNext - static_cast<long>(serveA);
        addAnswer(alpha, q, answer, serveR_.col(static_cast<Eigen::Index>(serveA)));
      }
      if (q.kind == QKind::kStall) continueOnAny(q, cont, next);  // its one answer: any
      else next[observationOf(q, answer)] = cont;
    }
  }
  return addVector(alpha, action, depth, mk, next, ex);
}

void CertifiedDialogSolver::Impl::frontierPlan(
    const std::int16_t* key, const Eigen::VectorXd& b, double reach, Eigen::VectorXd& alpha,
    std::size_t& action, std::vector<long>& next, PlanExport& ex) const {
  // The plan behind a commit lower bound, when it beats serving now.
  const SlotCode& rc = slot_[revealed_];
  std::vector<std::int16_t> sub(key, key + stride_), canonSub(stride_);
  std::fill(sub.begin() + static_cast<long>(rc.offset),
            sub.begin() + static_cast<long>(rc.offset + rc.n * rc.width), 0);
  std::vector<std::size_t> sperm;
  const std::size_t o1 = slot_[0].n, o2 = o1 + slot_[1].n;
  double bestCommit = alpha.dot(b) + 1e-9 * (1.0 + std::abs(alpha.dot(b)));
  std::size_t bestR = kNone;
  for (std::size_t r = 0; r < rc.n; ++r) {
    sub[rc.offset] = static_cast<std::int16_t>(r);
    canonSub = sub;
    canonicalize(canonSub.data(), &sperm, 1 << revealed_);
    const std::size_t i = subTable_.find(canonSub.data());
    if (i == kNone || subAlphaAt_[i] == kNoAlpha) continue;
    const double* a = &subAlpha_[subAlphaAt_[i]];
    double v = 0.0;
    for (std::size_t c = 0; c < nReq_; ++c) {
      const auto& pt = parts_[c];
      v += a[c] * b(static_cast<Eigen::Index>(
                      d_.requestIndex(sperm[pt[0]], sperm[o1 + pt[1]], sperm[o2 + pt[2]])));
    }
    if (v > bestCommit) bestCommit = v, bestR = r;
  }
  // Or a question about the room first, then the commit plan best for its answer (the
  // next turn's plans, in this key's request order).
  std::size_t look = kNone;
  std::vector<std::size_t> lookRoom;
  if (o_.roomLookahead && !roomLooks_.empty()) {
    std::vector<Eigen::VectorXd> next(rc.n);
    const double* A[kMaxValues];
    bool all = true;
    ++sub[0];
    for (std::size_t r = 0; r < rc.n && all; ++r) {
      A[r] = nullptr;
      double w = 0.0;
      for (std::size_t s = 0; s < nReq_; ++s)
        if (parts_[s][revealed_] == r) w += b(static_cast<Eigen::Index>(s));
      if (!(w > 0.0)) continue;
      sub[rc.offset] = static_cast<std::int16_t>(r);
      canonSub = sub;
      canonicalize(canonSub.data(), &sperm, 1 << revealed_);
      const std::size_t i = subTable_.find(canonSub.data());
      if (i == kNone || subAlphaAt_[i] == kNoAlpha) { all = false; break; }
      const double* a = &subAlpha_[subAlphaAt_[i]];
      next[r].resize(static_cast<Eigen::Index>(nReq_));
      for (std::size_t c = 0; c < nReq_; ++c) {
        const auto& pt = parts_[c];
        next[r](static_cast<Eigen::Index>(d_.requestIndex(sperm[pt[0]], sperm[o1 + pt[1]], sperm[o2 + pt[2]]))) = a[c];
      }
      A[r] = next[r].data();
    }
    --sub[0];
    std::size_t li = kNone;
    if (all && lookaheadValue(b, A, &li, &lookRoom) > bestCommit && li != kNone) look = li;
  }
  if (look != kNone) {
    const Question& q = questions_[roomLooks_[look].qi];
    alpha.setConstant(-q.cost);
    action = q.action;
    ++sub[0];
    for (std::size_t o = 0; o < roomLooks_[look].answers; ++o) {
      sub[rc.offset] = static_cast<std::int16_t>(lookRoom[o]);
      const std::size_t vi = subPlanVector(sub.data(), reach, 0.0, ex);
      next[observationOf(q, o)] = static_cast<long>(vi);
      addAnswer(alpha, q, o, ex.vectors[vi]);
    }
    --sub[0];
  } else if (bestR != kNone) {
    sub[rc.offset] = static_cast<std::int16_t>(bestR);
    // Followed to its end (floor 0): the sub-dialog is finite and its plans memoised, and
    // a commit plan cut by serving early loses most of its value.
    const std::size_t vi = subPlanVector(sub.data(), reach, 0.0, ex);
    alpha = ex.vectors[vi];
    action = ex.tags[vi].first;
    next.assign(ex.next.begin() + static_cast<long>(vi * ex.obs),
                ex.next.begin() + static_cast<long>((vi + 1) * ex.obs));
  }
}

std::size_t CertifiedDialogSolver::Impl::subPlanVector(
    const std::int16_t* subKey, double reach, double floor, PlanExport& ex) const {
  // "S" + key: sub keys share planVector's memo without meeting its (shorter) keys
  const std::string mk = "S" + std::string(reinterpret_cast<const char*>(subKey),
                                           stride_ * sizeof(std::int16_t));
  const auto it = ex.memo.find(mk);
  if (it != ex.memo.end()) return it->second;
  const int depth = subKey[0];
  const SlotCode& rc = slot_[revealed_];
  const std::size_t fixed = static_cast<std::size_t>(subKey[rc.offset]);
  std::vector<std::int16_t> canon(subKey, subKey + stride_), own(subKey, subKey + stride_);
  std::vector<std::size_t> perm;
  canonicalize(canon.data(), &perm, 1 << revealed_);
  const std::size_t idx = subTable_.find(canon.data());
  const int choice = idx == kNone || reach < floor || depth >= horizon_ ? kSubServe : subChoice_[idx];
  std::fill(own.begin() + static_cast<long>(rc.offset),
            own.begin() + static_cast<long>(rc.offset + rc.n * rc.width), 0);
  Eigen::VectorXd b;
  belief(own.data(), b, revealed_, fixed);
  Eigen::VectorXd alpha(static_cast<Eigen::Index>(nReq_));
  std::size_t action;
  std::vector<long> next(ex.obs, -1);
  if (choice == kSubServe) {
    std::size_t a = 0;
    serveValue(b, &a);
    alpha = serveR_.col(static_cast<Eigen::Index>(a));
    action = d_.serveAction(a);
  } else {
    const Question q = actualQuestion(static_cast<std::size_t>(choice), perm);
    action = q.action;
    alpha.setConstant(-q.cost);
    std::vector<std::int16_t> kid(subKey, subKey + stride_);
    if (q.kind == QKind::kStall || q.slot == revealed_) {  // asked, its answer not used
      ++kid[0];
      const std::size_t ci = subPlanVector(kid.data(), reach, floor, ex);
      continueOnAny(q, static_cast<long>(ci), next);
      alpha += gamma_ * ex.vectors[ci];
    } else {
      std::array<Eigen::VectorXd, kSlots> m;
      marginals(b, m);
      for (std::size_t answer = 0; answer < numAnswers(q); ++answer) {
        const double p = answerProb(m[q.slot], q, answer);
        childKey(subKey, q, answer, kid.data());
        canonicalize(kid.data(), nullptr, 1 << revealed_, false);
        const std::size_t ci = subPlanVector(kid.data(), reach * p, floor, ex);
        next[observationOf(q, answer)] = static_cast<long>(ci);
        addAnswer(alpha, q, answer, ex.vectors[ci]);
      }
    }
  }
  return addVector(alpha, action, depth, mk, next, ex);
}

void CertifiedDialogSolver::Impl::addAnswer(Eigen::VectorXd& alpha, const Question& q,
                                            std::size_t answer, const Eigen::VectorXd& child) const {
  for (std::size_t s = 0; s < nReq_; ++s)
    alpha(static_cast<Eigen::Index>(s)) +=
        gamma_ * answerLikelihood(q, answer, parts_[s][q.slot]) * child(static_cast<Eigen::Index>(s));
}

std::size_t CertifiedDialogSolver::Impl::observationOf(const Question& q, std::size_t answer) const {
  if (q.kind == QKind::kConfirm) return answer == 1 ? d_.obsYes() : d_.obsNo();
  return q.slot == 0 ? d_.obsItem(answer) : q.slot == 1 ? d_.obsRoom(answer) : d_.obsPerson(answer);
}

void CertifiedDialogSolver::Impl::continueOnAny(const Question& q, long child,
                                                std::vector<long>& next) const {
  for (std::size_t o : d_.model().possibleObservations(q.action)) next[o] = child;
}

std::size_t CertifiedDialogSolver::Impl::addVector(
    const Eigen::VectorXd& alpha, std::size_t action, int depth, const std::string& mk,
    const std::vector<long>& next, PlanExport& ex) const {
  ex.vectors.push_back(alpha);
  ex.tags.push_back({action, turnsUsed_ + depth});
  ex.next.insert(ex.next.end(), next.begin(), next.end());
  ex.memo.emplace(mk, ex.vectors.size() - 1);
  return ex.vectors.size() - 1;
}

// ---------------------------------------------------------------------------------------------

CertifiedDialogSolver::CertifiedDialogSolver(const DialogPomdp& dialog, const Eigen::VectorXd& root,
                                             int turnsUsed, CertifiedSolverOptions options)
    : impl_(std::make_unique<Impl>(dialog, root, turnsUsed, options)) {}

CertifiedDialogSolver::~CertifiedDialogSolver() = default;

bool CertifiedDialogSolver::solve() { return impl_->run(std::numeric_limits<std::size_t>::max()); }

bool CertifiedDialogSolver::runTrials(std::size_t trials) { return impl_->run(trials); }

CertifiedReport CertifiedDialogSolver::report() const {
  CertifiedReport r;
  const auto& nd = impl_->nodes_[impl_->rootIndex_];
  r.lower = nd.lower;
  r.upper = nd.upper;
  r.seconds = impl_->seconds_;
  r.trials = impl_->trials_;
  r.nodes = impl_->table_.size();
  r.expanded = impl_->expanded_;
  r.subNodes = impl_->subTable_.size();
  r.subCapped = impl_->subCapped_;
  r.sharedCuts = impl_->sharedCuts_;
  r.crossings = impl_->crossings_;
  r.bytes = impl_->bytes();
  r.stop = impl_->stop_;
  return r;
}

std::vector<CertifiedDialogSolver::NodeBounds> CertifiedDialogSolver::nodeBounds(
    std::size_t maxNodes) const {
  const Impl& m = *impl_;
  std::vector<NodeBounds> out;
  std::vector<std::int16_t> kid(m.stride_);
  for (std::size_t n = 0; n < m.nodes_.size() && out.size() < maxNodes; ++n) {
    NodeBounds nb;
    const std::int16_t* key = m.table_.key(n);
    if (!m.belief(key, nb.belief)) continue;
    nb.turnsUsed = m.turnsUsed_ + key[0];
    nb.lower = m.nodes_[n].lower;
    nb.upper = m.effUpper(n);  // raw: a crossing shows
    out.push_back(std::move(nb));
    // Its kept children (not nodes), with the bounds a backup reads.
    if (!m.leafCache_ || !m.expandedFlags_[n] || key[0] >= m.horizon_) continue;
    const std::uint32_t* slots = m.slotsOf(n);
    std::array<Eigen::VectorXd, kSlots> mg;
    m.marginals(out.back().belief, mg);
    for (std::size_t qi = 0; qi < m.questions_.size(); ++qi)
      for (std::size_t answer = 0; answer < m.numAnswers(m.questions_[qi]); ++answer) {
        const Question& q = m.questions_[qi];
        const std::uint32_t* w = slots + 2 * (m.posOf_[qi] + answer);
        if (!(m.answerProb(mg[q.slot], q, answer) > 1e-300) || w[1] == Impl::kLinked ||
            out.size() >= maxNodes)
          continue;
        m.childKey(key, q, answer, kid.data());
        m.canonicalize(kid.data());
        NodeBounds leaf;
        if (!m.belief(kid.data(), leaf.belief)) continue;
        leaf.turnsUsed = m.turnsUsed_ + kid[0];
        m.unpackSlot(w, leaf.upper, leaf.lower);
        out.push_back(std::move(leaf));
      }
  }
  return out;
}

std::size_t CertifiedDialogSolver::rootAction() const {
  // The exported policy's action (an unexpanded root's lower bound can be a frontier plan,
  // which starts with a question).
  const Impl& m = *impl_;
  Eigen::VectorXd b;
  m.belief(m.table_.key(m.rootIndex_), b);
  pomdp::Belief full = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(m.nReq_ + 1));
  full.head(static_cast<Eigen::Index>(m.nReq_)) = b;
  return policy().bestAction(full, m.turnsUsed_);
}

pomdp::TurnLimitedPolicy CertifiedDialogSolver::policy() const {
  const Impl& m = *impl_;
  const int limit = m.d_.spec().turnLimit;
  pomdp::TurnLimitedPolicy pol(m.nReq_ + 1, limit);
  Impl::PlanExport ex;
  ex.obs = m.d_.model().getO();
  std::vector<std::int16_t> k0(m.stride_, 0);
  const double floor = 1e-7;  // reach probability below which a plan ends at the frontier
  const auto reach = m.policyReach(floor);
  m.planVector(k0.data(), reach, floor, ex);
  Eigen::VectorXd full(static_cast<Eigen::Index>(m.nReq_ + 1));
  for (std::size_t i = 0; i < ex.vectors.size(); ++i) {
    full.head(static_cast<Eigen::Index>(m.nReq_)) = ex.vectors[i];
    full(static_cast<Eigen::Index>(m.nReq_)) = 0.0;
    pol.add(full, ex.tags[i].first, ex.tags[i].second);
  }
  for (std::size_t a = 0; a < m.nReq_; ++a) {  // "serve now" plans, usable at every turn
    full.head(static_cast<Eigen::Index>(m.nReq_)) = m.serveR_.col(static_cast<Eigen::Index>(a));
    full(static_cast<Eigen::Index>(m.nReq_)) = 0.0;
    pol.add(full, m.d_.serveAction(a), limit);
  }
  const long served = static_cast<long>(ex.vectors.size());
  for (long& n : ex.next)
    if (n <= Impl::kServeNext) n = served + (Impl::kServeNext - n);
  ex.next.resize(pol.size() * ex.obs, -1);  // serve plans end: no continuation
  pol.setPlans(ex.obs, std::move(ex.next));
  return pol;
}

double CertifiedDialogSolver::exactValue(const DialogPomdp& dialog, std::size_t maxNodes) {
  Impl impl(dialog, Eigen::VectorXd(), 0, CertifiedSolverOptions{});
  std::unordered_map<std::string, double> memo;
  std::vector<std::int16_t> k0(impl.stride_, 0);
  return impl.exactValue(k0.data(), 0, memo, maxNodes);
}

}  // namespace dialog
}  // namespace krr
