/**
 * @file resource_locator.h
 * @brief Where the repository's resources (config/, maps/) are, so that every program works
 * from any directory.
 *
 * The core is ROS-free, so the catkin package path is read the way roslib reads it, from the
 * environment of a sourced workspace ($ROS_PACKAGE_PATH, and the source spaces that the
 * `.catkin` file of each $CMAKE_PREFIX_PATH prefix names), not through ros::package.
 */
#pragma once

#include <string>

namespace krr {

/**
 * @brief The repository root: the first of
 *  1. `hint` if not empty (a --root option), as given;
 *  2. $KRR_ROOT if set, as given;
 *  3. two directories above the krr_core package found on $ROS_PACKAGE_PATH or in a catkin
 *     source space of $CMAKE_PREFIX_PATH (src/krr_core -> the checkout);
 *  4. the executable's directory and its parents (catkin_ws/devel/lib/krr_core lies inside);
 *  5. the working directory and its parents;
 * where 3 to 5 count only if they hold `marker`.
 * @throws ConfigError listing where it looked.
 */
std::string findRepositoryRoot(const std::string& hint = "",
                               const std::string& marker = "config/navigation.yaml");

/**
 * @brief `given` if not empty (a path option the user set, relative to the working directory),
 * else `relative` under findRepositoryRoot(root_hint) (the program's default).
 */
std::string resourcePath(const std::string& given, const std::string& relative,
                         const std::string& root_hint = "");

/// @brief Help text of the --root option: where the root is when they are not given.
extern const char* const kRepositoryRootHelp;

}  // namespace krr
