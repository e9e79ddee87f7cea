// reasoner_node: the robot's knowledge bases as ROS services (krr_ros::ReasonerNode,
// include/krr_ros/reasoner_node.h; its update transaction is the core's krr::kb::KnowledgeStore).
#include "krr_ros/reasoner_node.h"
#include "krr_ros/run_node.h"

int main(int argc, char** argv) {
  return krr_ros::runNode<krr_ros::ReasonerNode>(argc, argv, "reasoner_node", "reasoner");
}
