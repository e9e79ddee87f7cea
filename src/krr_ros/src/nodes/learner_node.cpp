// learner_node: see include/krr_ros/learner_node.h (the node class lives in libkrr_ros).
#include "krr_ros/learner_node.h"
#include "krr_ros/run_node.h"

int main(int argc, char** argv) {
  return krr_ros::runNode<krr_ros::LearnerNode>(argc, argv, "learner_node", "learner");
}
