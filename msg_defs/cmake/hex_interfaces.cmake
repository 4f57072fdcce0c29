# What both interface packages here (hex_control_msgs, and tf2_msgs for the venv) call before
# rosidl_generate_interfaces, after find_package(rosidl_default_generators).

# Wheel quirk (ROS 2 from PyPI): the exported *__rosidl_generator_py targets of the
# dependency packages list the wheel builder's include directory
# (/opt/python/cp311-cp311/include/python3.11), which does not exist here. CMake
# refuses targets with missing include directories, so drop the missing entries.
# In a normal ROS 2 install every entry exists and this changes nothing.
function(hex_drop_missing_wheel_includes)
  foreach(dep ${ARGN})
    set(target "${dep}::${dep}__rosidl_generator_py")
    if(TARGET ${target})
      get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
      if(dirs)
        set(existing "")
        foreach(dir ${dirs})
          if(dir MATCHES "^\\$<" OR EXISTS "${dir}")
            list(APPEND existing "${dir}")
          endif()
        endforeach()
        set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${existing}")
      endif()
    endif()
  endforeach()
endfunction()

# Python only (the Makefile's venv builds, and test_colcon_build's colcon build): the C++
# generators and type supports, which nothing here loads, left out; a user's colcon or ament
# build leaves HEX_PYTHON_ONLY OFF and gets them all. The generators are those that
# find_package(rosidl_default_generators) registered: call it after that.
function(hex_python_only)
  option(HEX_PYTHON_ONLY "generate only what rclpy loads (C and Python)" OFF)
  if(NOT HEX_PYTHON_ONLY)
    return()
  endif()
  if(NOT AMENT_EXTENSIONS_rosidl_generate_idl_interfaces)
    message(FATAL_ERROR "hex_python_only() before find_package(rosidl_default_generators)")
  endif()
  set(python_only "")
  foreach(extension ${AMENT_EXTENSIONS_rosidl_generate_idl_interfaces})
    if(NOT extension MATCHES "^rosidl_(generator_cpp|typesupport_cpp|typesupport_fastrtps_cpp|typesupport_introspection_cpp):")
      list(APPEND python_only "${extension}")
    endif()
  endforeach()
  set(AMENT_EXTENSIONS_rosidl_generate_idl_interfaces "${python_only}" PARENT_SCOPE)
endfunction()

# A unity build (CMAKE_UNITY_BUILD, as the Makefile's and test_colcon_build's colcon builds
# configure it: the package's 122 C files in 31 compiler runs, 14 unity files and the 17
# description sources; 46 -> 34 CPU s). Call after rosidl_generate_interfaces: each message's
# type description source defines the same static hashes of the types it uses, so those
# sources are compiled on their own.
function(hex_unity_safe target_prefix)
  if(NOT CMAKE_UNITY_BUILD)
    return()
  endif()
  set(target "${target_prefix}__rosidl_generator_c")
  get_target_property(sources ${target} SOURCES)
  foreach(source ${sources})
    if(source MATCHES "__description\\.c$")
      set_source_files_properties(${source} PROPERTIES SKIP_UNITY_BUILD_INCLUSION ON)  # this directory's target
    endif()
  endforeach()
endfunction()
