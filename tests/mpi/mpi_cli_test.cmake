# `mpirun -np 2 soda run ... --territories K` prints the hash of the
# threaded 1-territory run, writes the JSON (with its per-rank traffic) from
# rank 0 only, gives it with speculation and SyncTest too, and refuses a
# bad --ranks-worlds or --validate with exit 2.
# Run by ctest: cmake -DSODA=... -DMPIEXEC=... -P mpi_cli_test.cmake
set(scene --scene falling-cubes --n 120 --steps 60)

function(hash_of out text)
  string(REGEX MATCH "state_hash ([0-9a-f]+)" m "${text}")
  if(NOT m)
    message(FATAL_ERROR "no state_hash in:\n${text}")
  endif()
  set(${out} ${CMAKE_MATCH_1} PARENT_SCOPE)
endfunction()

execute_process(COMMAND ${SODA} run ${scene} --territories 1 OUTPUT_VARIABLE one RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "soda run --territories 1 failed (${rc}):\n${one}")
endif()
hash_of(reference "${one}")

set(json ${CMAKE_CURRENT_BINARY_DIR}/mpi_cli_run.json)
file(REMOVE ${json})
execute_process(COMMAND ${MPIEXEC} --oversubscribe -np 2 ${SODA} run ${scene} --territories 3 --ranks-worlds 0,1,1
                        --json ${json}
                OUTPUT_VARIABLE two ERROR_VARIABLE two_err RESULT_VARIABLE rc TIMEOUT 120)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "mpirun -np 2 soda run failed (${rc}):\n${two}\n${two_err}")
endif()
hash_of(ranked "${two}")
if(NOT ranked STREQUAL reference)
  message(FATAL_ERROR "3 territories on 2 ranks: state_hash ${ranked}, one territory ${reference}")
endif()
string(REGEX MATCHALL "state_hash" printed "${two}")
list(LENGTH printed n)
if(NOT n EQUAL 1)
  message(FATAL_ERROR "expected one summary (rank 0's), got ${n}:\n${two}")
endif()
file(READ ${json} j)
string(JSON hash_json GET "${j}" state_hash)
string(JSON ranks LENGTH "${j}" ranks)
string(JSON worlds1 GET "${j}" ranks 1 worlds)
if(NOT ranks EQUAL 2 OR NOT worlds1 EQUAL 2)
  message(FATAL_ERROR "JSON: expected 2 ranks, rank 1 with 2 worlds:\n${j}")
endif()
message(STATUS "one territory ${reference}; 3 territories on 2 ranks ${ranked} (JSON ${hash_json})")

# Speculation and SyncTest over ranks: the same hash.
execute_process(COMMAND ${MPIEXEC} --oversubscribe -np 2 ${SODA} run ${scene} --territories 3 --anticipation 8
                        --eager-bets --sync-test 2
                OUTPUT_VARIABLE spec ERROR_VARIABLE spec_err RESULT_VARIABLE rc TIMEOUT 120)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "mpirun -np 2 soda run --anticipation 8 failed (${rc}):\n${spec}\n${spec_err}")
endif()
hash_of(speculated "${spec}")
if(NOT speculated STREQUAL reference)
  message(FATAL_ERROR "3 territories on 2 ranks, anticipation 8: state_hash ${speculated}, one territory ${reference}")
endif()

foreach(bad "--ranks-worlds;0,2,1" "--ranks-worlds;0,1" "--validate")
  execute_process(COMMAND ${MPIEXEC} --oversubscribe -np 2 ${SODA} run ${scene} --territories 3 ${bad}
                  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 60)
  if(NOT rc EQUAL 2 OR NOT err MATCHES "soda: error: ")
    message(FATAL_ERROR "${bad}: expected exit 2 with an error, got ${rc}:\n${out}\n${err}")
  endif()
endforeach()
