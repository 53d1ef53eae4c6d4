# CTest gl_integration: runs examples/gl_integration (EXAMPLE) in DIR and checks what it wrote: the
# PNG exists and is not trivially small, and its linear EXR matches `penumbra render` (CLI), the
# OpenCL-only path on the same scene, sky, lights, camera and defaults, within BOUND (relative
# RMSE over geometry pixels). The bound is set in tests/CMakeLists.txt, with its reason.
file(REMOVE_RECURSE ${DIR})
file(MAKE_DIRECTORY ${DIR})
execute_process(COMMAND ${EXAMPLE} ${DIR}/gl_integration.png ${DIR}/gl_integration.exr 320x180
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "gl_integration failed (${rc}): ${out}${err}")
endif()
message(STATUS "${out}")
foreach(f gl_integration.png gl_integration.exr)
  if(NOT EXISTS ${DIR}/${f})
    message(FATAL_ERROR "gl_integration did not write ${f}")
  endif()
endforeach()
file(SIZE ${DIR}/gl_integration.png png_bytes)
if(png_bytes LESS 10000)  # a flat or empty 320x180 picture compresses below this
  message(FATAL_ERROR "gl_integration.png is only ${png_bytes} bytes")
endif()
# --no-contact-shadows, --auto-exact-share 0: the interop receives no triangles, so the example
# has no contact shadows and its `auto` gives no light exact visibility.
execute_process(COMMAND ${CLI} render --size 320x180 --no-contact-shadows --auto-exact-share 0
                --out ${DIR}/opencl.exr
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "penumbra render failed (${rc}): ${err}")
endif()
execute_process(COMMAND ${CLI} compare ${DIR}/gl_integration.exr ${DIR}/opencl.exr
                --out ${DIR}/metrics.json RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "penumbra compare failed (${rc}): ${err}")
endif()
file(READ ${DIR}/metrics.json json)
string(JSON rel GET "${json}" relative_rmse)
message(STATUS "gl_integration vs penumbra render: relative RMSE ${rel} (bound ${BOUND})")
if(NOT rel LESS BOUND)
  message(FATAL_ERROR "gl_integration differs from penumbra render: relative RMSE ${rel} >= ${BOUND}")
endif()
