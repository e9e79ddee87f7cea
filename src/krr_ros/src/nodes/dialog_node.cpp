// dialog_node: the delivery robot's dialog manager (krr_ros::DialogNode,
// include/krr_ros/dialog_node.h; the dialog itself is the core's krr::dialog::DeliveryManager).
#include "krr_ros/dialog_node.h"
#include "krr_ros/run_node.h"

int main(int argc, char** argv) {
  return krr_ros::runNode<krr_ros::DialogNode>(argc, argv, "dialog_node", "dialog");
}
