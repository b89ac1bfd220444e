# docs/architecture.md names every library header (its "Headers" index): a
# newcomer finds each header's folder, library and purpose there. Run as a test:
# cmake -DSOURCE_DIR=<repo> -P cmake/check_doc_headers.cmake. Prints one line per
# header the document does not name and fails; prints a count otherwise.
# Library headers: those of core/, gl/, nodes/, dds/, record/, launch/,
# foxglove/, ros2/ and the tools' own modules in tools/ (tests, fuzz targets and
# benches have none to document).
if(NOT SOURCE_DIR)
  message(FATAL_ERROR "check_doc_headers: pass -DSOURCE_DIR=<the repository>")
endif()
set(doc ${SOURCE_DIR}/docs/architecture.md)
if(NOT EXISTS ${doc})
  message(FATAL_ERROR "check_doc_headers: ${doc} does not exist")
endif()
file(READ ${doc} text)
file(GLOB_RECURSE headers RELATIVE ${SOURCE_DIR}
     ${SOURCE_DIR}/core/*.h ${SOURCE_DIR}/gl/*.h ${SOURCE_DIR}/nodes/*.h ${SOURCE_DIR}/dds/*.h
     ${SOURCE_DIR}/record/*.h ${SOURCE_DIR}/launch/*.h ${SOURCE_DIR}/foxglove/*.h ${SOURCE_DIR}/ros2/*.h
     ${SOURCE_DIR}/openxr/*.h ${SOURCE_DIR}/tools/*.h)
list(SORT headers)
set(missing 0)
foreach(h IN LISTS headers)
  get_filename_component(name ${h} NAME)
  string(REPLACE "." "\\." pattern ${name})
  # A name stands alone: `tile_set.h`, not a longer name ending in it.
  if(NOT text MATCHES "(^|[^A-Za-z0-9_])${pattern}")
    message("${h} is not named in docs/architecture.md")
    math(EXPR missing "${missing} + 1")
  endif()
endforeach()
list(LENGTH headers n)
if(missing GREATER 0)
  message(FATAL_ERROR "check_doc_headers: ${missing} of ${n} headers are not named in docs/architecture.md")
endif()
message("check_doc_headers: docs/architecture.md names all ${n} headers")
