# cmake -P script: install, configure the consumer against the installed tree, build, run.
file(REMOVE_RECURSE "${PREFIX}" "${CONSUMER_BUILD}")
foreach(step
    "${CMAKE_COMMAND};--install;${BUILD_DIR};--prefix;${PREFIX}"
    "${CMAKE_COMMAND};-S;${CONSUMER_SOURCE};-B;${CONSUMER_BUILD};-G;${GENERATOR};-DCMAKE_PREFIX_PATH=${PREFIX};-DXPOSE_GEOMETRY=${XPOSE_GEOMETRY}"
    "${CMAKE_COMMAND};--build;${CONSUMER_BUILD}"
    "${CONSUMER_BUILD}/xpose-consumer")
  execute_process(COMMAND ${step} RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT result EQUAL 0)
    message(FATAL_ERROR "step failed (${result}): ${step}\n${out}\n${err}")
  endif()
endforeach()
message(STATUS "consumer output: ${out}")

# The Python package from the installed tree alone: import it and run a filter.
if(PYTHON_EXECUTABLE)
  execute_process(
    COMMAND "${CMAKE_COMMAND}" -E env "PYTHONPATH=${PREFIX}/${PYTHON_DESTINATION}"
      "${PYTHON_EXECUTABLE}" -c "import xpose, sys; f = xpose.vtkXPStereoRegistrationFilter(); print(xpose.__file__); sys.exit(0 if f.GetShrinkFactor() == 1 else 1)"
    RESULT_VARIABLE result OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT result EQUAL 0 OR NOT out MATCHES "^${PREFIX}/")
    message(FATAL_ERROR "import xpose from ${PREFIX}/${PYTHON_DESTINATION} failed (${result}):\n${out}\n${err}")
  endif()
  message(STATUS "python: import xpose from ${out}")
endif()
