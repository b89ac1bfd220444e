# The layering check (docs/architecture.md, "Layers"): every #include
# "hullpipe/<folder>/..." in a library's sources must name a folder that library
# may depend on, so dependencies point down and no tool links what it does not
# use. Run as a test: cmake -DSOURCE_DIR=<repo> -P cmake/check_layers.cmake.
# Prints one line per offending include and fails; prints a summary otherwise.
#
# Tests (*_test.cc) and the test helpers (core/hullpipe/testing, test_rig.h) may
# include any core folder: they build fixtures from the layers above them.
# geometry/conventions.h, the conventions header, depends on nothing and is
# allowed everywhere.
if(NOT SOURCE_DIR)
  message(FATAL_ERROR "check_layers: pass -DSOURCE_DIR=<the repository>")
endif()

# <source folder>|<folders its includes may name>. From the bottom up.
set(rules
  "core/hullpipe/util|util"
  "core/hullpipe/pipeline|util pipeline"
  "core/hullpipe/geometry|util geometry"
  "core/hullpipe/capture|util geometry capture"
  "core/hullpipe/reconstruction|util pipeline geometry reconstruction"
  "core/hullpipe/collision|util pipeline geometry reconstruction collision"
  "core/hullpipe/evaluation|util pipeline geometry capture reconstruction evaluation"
  "core/hullpipe/segmentation|util pipeline geometry capture reconstruction segmentation"
  "core/hullpipe/models|util pipeline geometry reconstruction collision models"
  "core/hullpipe/scenes|util pipeline geometry reconstruction collision models scenes"
  "gl|util pipeline geometry reconstruction collision gl"
  # (evaluation: the synthetic scene is a capture source, capture_flags.h opens
  # it; launch: launch_flags.h makes a launch description's context)
  "nodes|util pipeline geometry capture reconstruction collision evaluation segmentation models scenes launch nodes"
  "record|util record"
  "launch/hullpipe|util launch"
  # (the Foxglove channels convert the pipeline's samples, as dds's conversions)
  "foxglove|util pipeline geometry reconstruction segmentation dds foxglove"
  # (ROS 2 messages of the pipeline's samples, as dds's conversions)
  "ros2|util pipeline geometry reconstruction dds ros2"
  # (an OpenXR runtime's views as the pipeline's eye views, no DDS; gl for
  # xr_display.cc alone: hullpipe_openxr_client does not link hullpipe_gl)
  "openxr|util pipeline geometry reconstruction gl openxr")
# The DDS wrapper (hullpipe_dds_base) sits on the pipeline's types alone; the
# conversions (hullpipe_dds) on the core types they convert. Neither on nodes or gl.
set(dds_base_files dds.h dds.cc cdr.h cdr.cc node.h node.cc topics.h owned_sample.h node_stats_convert.h
                   node_stats_convert.cc)
set(dds_base_allowed util pipeline dds)
set(dds_allowed util pipeline geometry reconstruction segmentation dds)

set(violations 0)
set(checked 0)
function(check_file file allowed)
  get_filename_component(name ${file} NAME)
  if(name MATCHES "_test\\.cc$" OR name STREQUAL "test_rig.h")
    return()
  endif()
  file(STRINGS ${file} lines REGEX "^[ \t]*#[ \t]*include[ \t]+\"hullpipe/")
  foreach(line IN LISTS lines)
    string(REGEX REPLACE "^[ \t]*#[ \t]*include[ \t]+\"hullpipe/([^\"]*)\".*$" "\\1" path "${line}")
    if(path STREQUAL "geometry/conventions.h")
      continue()
    endif()
    string(REGEX REPLACE "/.*$" "" folder "${path}")
    if(NOT path MATCHES "/")
      continue()  # "hullpipe.h"-style generated headers are not a layer
    endif()
    list(FIND allowed ${folder} found)
    if(found EQUAL -1)
      file(RELATIVE_PATH rel ${SOURCE_DIR} ${file})
      message("layering: ${rel} includes hullpipe/${path}: ${folder} is above it (allowed: ${allowed})")
      math(EXPR n "${violations} + 1")
      set(violations ${n} PARENT_SCOPE)
    endif()
  endforeach()
  math(EXPR n "${checked} + 1")
  set(checked ${n} PARENT_SCOPE)
endfunction()

foreach(rule IN LISTS rules)
  string(REPLACE "|" ";" parts "${rule}")
  list(GET parts 0 dir)
  list(GET parts 1 allowed)
  string(REPLACE " " ";" allowed "${allowed}")
  file(GLOB_RECURSE files ${SOURCE_DIR}/${dir}/*.h ${SOURCE_DIR}/${dir}/*.cc)
  if(NOT files)
    message("layering: no sources under ${dir}: the rule table is out of date")
    math(EXPR violations "${violations} + 1")
  endif()
  foreach(f IN LISTS files)
    check_file(${f} "${allowed}")
  endforeach()
endforeach()

file(GLOB dds_files ${SOURCE_DIR}/dds/include/hullpipe/dds/* ${SOURCE_DIR}/dds/src/*)
foreach(f IN LISTS dds_files)
  get_filename_component(name ${f} NAME)
  list(FIND dds_base_files ${name} base)
  if(base EQUAL -1)
    check_file(${f} "${dds_allowed}")
  else()
    check_file(${f} "${dds_base_allowed}")
  endif()
endforeach()

if(violations GREATER 0)
  message(FATAL_ERROR "layering: ${violations} include(s) point up (docs/architecture.md, \"Layers\")")
endif()
message("layering: ${checked} files checked, every include points down")
