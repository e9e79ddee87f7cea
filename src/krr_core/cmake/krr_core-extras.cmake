# Build settings shared by the C++ packages of KRR-RL (krr_core, krr_ros), in one place:
# krr_core includes this file itself and exports it (catkin_package CFG_EXTRAS), so every
# package that finds krr_core calls krr_build_settings() instead of repeating them.
macro(krr_build_settings)
  set(CMAKE_CXX_STANDARD 17)
  set(CMAKE_CXX_STANDARD_REQUIRED ON)
  if(NOT CMAKE_BUILD_TYPE)
    set(CMAKE_BUILD_TYPE Release)
  endif()
  add_compile_options(-Wall -Wextra)
endmacro()
