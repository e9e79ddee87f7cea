// navigation_node: see include/krr_ros/navigation_node.h (the node class lives in libkrr_ros).
#include "krr_ros/navigation_node.h"
#include "krr_ros/run_node.h"

int main(int argc, char** argv) {
  return krr_ros::runNode<krr_ros::NavigationNode>(argc, argv, "navigation_node", "navigation");
}
