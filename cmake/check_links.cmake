# What a tool links (docs/architecture.md, "Layers"): a binary that must not link
# GL or the algorithms has no EGL/GL library among its DT_NEEDED entries and
# defines no symbol of the core's algorithms or of hullpipe::gl. Run as a test:
#   cmake -DBINARY=<path> -DEXPECT=absent|present -P cmake/check_links.cmake
# EXPECT=present is the positive control (recon_node has both), so a check that
# finds nothing because it looks in the wrong place fails.
foreach(v BINARY EXPECT)
  if(NOT ${v})
    message(FATAL_ERROR "check_links: pass -D${v}=...")
  endif()
endforeach()
if(NOT EXISTS ${BINARY})
  message(FATAL_ERROR "check_links: ${BINARY} does not exist")
endif()
execute_process(COMMAND readelf -d ${BINARY} OUTPUT_VARIABLE dyn RESULT_VARIABLE rc1)
execute_process(COMMAND nm -C --defined-only ${BINARY} OUTPUT_VARIABLE syms RESULT_VARIABLE rc2)
if(NOT rc1 EQUAL 0 OR NOT rc2 EQUAL 0)
  message(FATAL_ERROR "check_links: readelf or nm failed on ${BINARY}")
endif()
set(found "")
foreach(lib libEGL libOpenGL libGL\\. libGLX)
  if(dyn MATCHES "NEEDED[^\n]*\\[${lib}")
    list(APPEND found "links ${lib}")
  endif()
endforeach()
# One symbol family per algorithm layer: volume query and sweep (§3.2-3.3),
# frameset assembly, the triangle query (§4.1), scenes, the GL twins.
foreach(sym "hullpipe::VolumeQuery::" "hullpipe::PlaneSweepCpu" "hullpipe::FramesetAssembler::"
            "hullpipe::TriangleQuery" "hullpipe::Ball" "hullpipe::gl::")
  string(FIND "${syms}" "${sym}" at)
  if(NOT at EQUAL -1)
    list(APPEND found "defines ${sym}")
  endif()
endforeach()
get_filename_component(name ${BINARY} NAME)
if(EXPECT STREQUAL "absent")
  if(found)
    string(REPLACE ";" ", " found "${found}")
    message(FATAL_ERROR "check_links: ${name} ${found}: it must link neither GL nor the algorithms")
  endif()
  message("check_links: ${name} links no GL and no algorithm")
else()
  if(NOT found MATCHES "libEGL" OR NOT found MATCHES "VolumeQuery")
    message(FATAL_ERROR "check_links: positive control failed: ${name} should link EGL and the volume query, found: ${found}")
  endif()
  message("check_links: ${name} (control): ${found}")
endif()
