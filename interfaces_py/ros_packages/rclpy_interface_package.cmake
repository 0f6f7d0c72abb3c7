# Shared by the CMakeLists.txt of every package here: an interface package for rclpy.
#
# Only the generators rclpy needs run: type descriptions (the type hashes), C structs, the C type
# supports Fast DDS and introspection use, and the Python bindings. A full ROS install builds the
# C++ ones too; nothing in this project reads C++ types, and leaving them out halves the set-up
# build. Every .msg, .srv and .action file of the package is generated.
#
#   rclpy_interface_package(<dependency packages...>)
macro(rclpy_interface_package)
  set(_dependencies ${ARGN})
  find_package(ament_cmake REQUIRED)
  find_package(rosidl_cmake REQUIRED)
  find_package(rosidl_generator_type_description REQUIRED)
  find_package(rosidl_generator_c REQUIRED)
  find_package(rosidl_typesupport_fastrtps_c REQUIRED)
  find_package(rosidl_typesupport_introspection_c REQUIRED)
  find_package(rosidl_typesupport_c REQUIRED)
  find_package(rosidl_generator_py REQUIRED)
  foreach(_dependency ${_dependencies})
    find_package(${_dependency} REQUIRED)
  endforeach()

  file(GLOB_RECURSE _interfaces RELATIVE "${CMAKE_CURRENT_SOURCE_DIR}"
    "${CMAKE_CURRENT_SOURCE_DIR}/msg/*.msg"
    "${CMAKE_CURRENT_SOURCE_DIR}/srv/*.srv"
    "${CMAKE_CURRENT_SOURCE_DIR}/action/*.action")
  list(SORT _interfaces)

  # Finding the message packages we depend on registers the C++ generators as well; keep only
  # the generators rclpy uses (package names not ending in _cpp).
  set(_rclpy_extensions)
  foreach(_extension ${AMENT_EXTENSIONS_rosidl_generate_idl_interfaces})
    string(REGEX MATCH "^[^:]+" _generator "${_extension}")
    if(NOT _generator MATCHES "_cpp$")
      list(APPEND _rclpy_extensions "${_extension}")
    endif()
  endforeach()
  set(AMENT_EXTENSIONS_rosidl_generate_idl_interfaces ${_rclpy_extensions})

  rosidl_generate_interfaces(${PROJECT_NAME} ${_interfaces} DEPENDENCIES ${_dependencies})
  ament_export_dependencies(rosidl_default_runtime)
  ament_package()
endmacro()
