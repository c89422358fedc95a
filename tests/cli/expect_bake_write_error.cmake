# dfb-bake when its output cannot be written (docs/operations.md "Exit codes"): exit code 4, one
# "dfb-bake: io_error: ..." line naming the output, and nothing left behind: neither the output nor
# the temporary file it writes first. Two cases: a missing folder, and an output path that is a
# folder (the rename into place fails after the whole file was written).
# Usage: cmake -DBAKE=path -DSCENE=scene.glb -DDIR=scratch-folder -P expect_bake_write_error.cmake
file(REMOVE_RECURSE ${DIR})
file(MAKE_DIRECTORY ${DIR}/taken.exr)
foreach(out ${DIR}/missing/shot.exr ${DIR}/taken.exr)
    execute_process(COMMAND ${BAKE} ${SCENE} -o ${out} --width 16 --height 9 --env-rays 0
                    RESULT_VARIABLE rc OUTPUT_VARIABLE stdout ERROR_VARIABLE err)
    if(NOT rc EQUAL 4)
        message(FATAL_ERROR "dfb-bake -o ${out} exited ${rc}, not 4\nstdout: ${stdout}\nstderr: ${err}")
    endif()
    string(REGEX MATCH "dfb-bake: io_error: [^\n]*${out}[^\n]*" line "${err}")
    if(line STREQUAL "")
        message(FATAL_ERROR "dfb-bake -o ${out}: no 'dfb-bake: io_error: ...${out}...' line on stderr:\n${err}")
    endif()
    message(STATUS "${line}")
endforeach()
file(GLOB left ${DIR}/*)
if(NOT left STREQUAL "${DIR}/taken.exr")
    message(FATAL_ERROR "dfb-bake left files behind in ${DIR}: ${left}")
endif()
file(REMOVE_RECURSE ${DIR})
