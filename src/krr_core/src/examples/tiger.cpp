#include "krr_core/examples/tiger.h"

namespace krr {
namespace examples {

pomdp::Model makeTiger(double discount, double listenAccuracy, double listenCost,
                       double treasureReward, double tigerPenalty) {
  // state 0 = tiger-left, 1 = tiger-right; action 0 listen, 1 open-left, 2 open-right.
  Eigen::MatrixXd listenT = Eigen::MatrixXd::Identity(2, 2);
  Eigen::MatrixXd resetT = Eigen::MatrixXd::Constant(2, 2, 0.5);
  Eigen::MatrixXd listenO(2, 2);
  listenO << listenAccuracy, 1.0 - listenAccuracy, 1.0 - listenAccuracy, listenAccuracy;
  Eigen::MatrixXd resetO = Eigen::MatrixXd::Constant(2, 2, 0.5);
  Eigen::MatrixXd r(2, 3);
  r << -listenCost, -tigerPenalty, treasureReward,  // tiger left
      -listenCost, treasureReward, -tigerPenalty;   // tiger right
  pomdp::Model m({listenT, resetT, resetT}, {listenO, resetO, resetO}, r, discount);
  m.setNames({"tiger-left", "tiger-right"}, {"listen", "open-left", "open-right"},
             {"tiger-left", "tiger-right"});
  return m;
}

}  // namespace examples
}  // namespace krr
