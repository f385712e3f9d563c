# `mpirun -np 2 soda run ... --territories K` prints the hash of the
# threaded 1-territory run, writes the JSON (with its per-rank traffic) from
# rank 0 only (each rank's Bullet objects its share, not the scene), gives
# it with speculation and SyncTest too, also for a scene
# with joints, with a solver pool, with inputs from a file and recording a
# replay, writing and resuming a checkpoint, validates every step
# (--validate: rank 0 prints the threaded run's census), and refuses a bad
# --ranks-worlds with exit 2.
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

# `soda run ${scene} --territories 3 ARGN` on 2 ranks: its output, after
# checking that it ran and printed `reference`, the 1-territory hash.
function(ranked_run out)
  execute_process(COMMAND ${MPIEXEC} --oversubscribe -np 2 ${SODA} run ${scene} --territories 3 ${ARGN}
                  OUTPUT_VARIABLE text ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 120)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "mpirun -np 2 soda run ${scene} ${ARGN} failed (${rc}):\n${text}\n${err}")
  endif()
  hash_of(ranked "${text}")
  if(NOT ranked STREQUAL reference)
    message(FATAL_ERROR "${scene}: 3 territories on 2 ranks (${ARGN}): state_hash ${ranked}, one territory ${reference}")
  endif()
  set(${out} "${text}" PARENT_SCOPE)
endfunction()

# Fails unless `pattern` occurs exactly once in `text` (one rank printed).
function(expect_once pattern text what)
  string(REGEX MATCHALL "${pattern}" found "${text}")
  list(LENGTH found n)
  if(NOT n EQUAL 1)
    message(FATAL_ERROR "${what}: expected \"${pattern}\" once (rank 0's), got ${n}:\n${text}")
  endif()
endfunction()

set(json ${CMAKE_CURRENT_BINARY_DIR}/mpi_cli_run.json)
file(REMOVE ${json})
ranked_run(two --ranks-worlds 0,1,1 --json ${json})
expect_once("state_hash" "${two}" "soda run on 2 ranks, its summary")
file(READ ${json} j)
string(JSON hash_json GET "${j}" state_hash)
string(JSON ranks LENGTH "${j}" ranks)
string(JSON worlds1 GET "${j}" ranks 1 worlds)
if(NOT ranks EQUAL 2 OR NOT worlds1 EQUAL 2)
  message(FATAL_ERROR "JSON: expected 2 ranks, rank 1 with 2 worlds:\n${j}")
endif()
message(STATUS "one territory ${reference}; 3 territories on 2 ranks: the same (JSON ${hash_json})")
# Each rank builds its worlds from its share of the scene: fewer Bullet
# objects than the scene's 120 cubes on either rank (each rank held every
# world's bodies, more than 120, before), and its peak memory is reported.
foreach(rank 0 1)
  string(JSON objects GET "${j}" ranks ${rank} bullet_objects)
  string(JSON rss GET "${j}" ranks ${rank} peak_rss_bytes)
  if(NOT objects LESS 120 OR NOT objects GREATER 0 OR NOT rss GREATER 0)
    message(FATAL_ERROR "JSON: rank ${rank} holds ${objects} Bullet objects (expected 1 .. 119), peak RSS ${rss}:\n${j}")
  endif()
  message(STATUS "rank ${rank}: ${objects} Bullet objects, peak RSS ${rss} bytes")
endforeach()

# Speculation and SyncTest over ranks: the same hash. The ranks compute the
# commit horizon in rounds (GVT) while speculating, none in lockstep.
set(spec_json ${CMAKE_CURRENT_BINARY_DIR}/mpi_cli_spec.json)
file(REMOVE ${spec_json})
ranked_run(spec --anticipation 8 --eager-bets --sync-test 2 --json ${spec_json})
file(READ ${spec_json} spec)
foreach(rank 0 1)
  string(JSON lockstep_rounds GET "${j}" ranks ${rank} gvt_rounds)
  string(JSON spec_rounds GET "${spec}" ranks ${rank} gvt_rounds)
  if(NOT lockstep_rounds EQUAL 0 OR NOT spec_rounds GREATER 0)
    message(FATAL_ERROR "rank ${rank}: ${lockstep_rounds} GVT rounds in lockstep (expected 0), ${spec_rounds} speculating (expected > 0)")
  endif()
  message(STATUS "rank ${rank}: ${spec_rounds} GVT rounds speculating, none in lockstep")
endforeach()

# --lb over ranks: every rank decides the same cessions from the gathered
# loads; the 1-territory hash, cells moved.
ranked_run(balanced --lb diffusive --lb-period 10 --anticipation 8)
expect_once("load balancing: [0-9]+ balance steps" "${balanced}" "--lb diffusive")
message(STATUS "--lb diffusive on 2 ranks: ${reference}")

# --validate: every step's census over the ranks; rank 0 prints the counts,
# those of the threaded run.
execute_process(COMMAND ${SODA} run ${scene} --territories 3 --validate OUTPUT_VARIABLE threaded RESULT_VARIABLE rc)
string(REGEX MATCH "validate: [^;]*" threaded_census "${threaded}")
ranked_run(validated --validate --anticipation 8)
expect_once("validate: " "${validated}" "--validate")
string(REGEX MATCH "validate: [^;]*" ranked_census "${validated}")
if(NOT threaded_census OR NOT ranked_census STREQUAL threaded_census)
  message(FATAL_ERROR "--validate on 2 ranks: '${ranked_census}', on threads '${threaded_census}'")
endif()
message(STATUS "--validate on 2 ranks: ${ranked_census}")

foreach(bad "--ranks-worlds;0,2,1" "--ranks-worlds;0,1")
  execute_process(COMMAND ${MPIEXEC} --oversubscribe -np 2 ${SODA} run ${scene} --territories 3 ${bad}
                  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 60)
  if(NOT rc EQUAL 2 OR NOT err MATCHES "soda: error: ")
    message(FATAL_ERROR "${bad}: expected exit 2 with an error, got ${rc}:\n${out}\n${err}")
  endif()
endforeach()

# Joints over ranks: ragdolls whose joint groups cross territory borders.
set(scene --scene ragdolls --n 6 --steps 80)
execute_process(COMMAND ${SODA} run ${scene} --territories 1 OUTPUT_VARIABLE one RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "soda run ${scene} --territories 1 failed (${rc}):\n${one}")
endif()
hash_of(reference "${one}")
ranked_run(ragdolls --anticipation 8)
message(STATUS "ragdolls 6: one territory ${reference}; 3 territories on 2 ranks, speculating: the same")

# A solver pool over ranks (--solver-threads 2): each rank's worlds share
# theirs, as on threads; cube-pile's heap is one large island. The same hash.
set(scene --scene cube-pile --n 600 --steps 60)
execute_process(COMMAND ${SODA} run ${scene} --territories 1 OUTPUT_VARIABLE one RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "soda run ${scene} --territories 1 failed (${rc}):\n${one}")
endif()
hash_of(reference "${one}")
ranked_run(pool --solver-threads 2)
ranked_run(pool_spec --solver-threads 2 --anticipation 8)
message(STATUS "cube-pile 600: one territory ${reference}; 3 territories on 2 ranks with --solver-threads 2: the same")

# Inputs from a file over ranks (`--inputs`): every rank reads them and each
# world applies those that concern it. A push, a velocity, a collision
# filter, a turned gravity, a body removed and one added: the threaded
# 1-territory run's hash, lockstep and speculating.
set(inputs ${CMAKE_CURRENT_BINARY_DIR}/mpi_cli_inputs.json)
file(WRITE ${inputs} [=[{"format": "soda-inputs", "version": 1, "inputs": [
 {"type": "apply_impulse", "step": 10, "id": 5, "impulse": [0, 30, 0]},
 {"type": "set_velocity", "step": 15, "id": 7, "linear_velocity": [2, 0, 0]},
 {"type": "set_collision_filter", "step": 20, "id": 4, "group": 16, "mask": 0},
 {"type": "set_gravity", "step": 25, "gravity": [1, -9.81, 0]},
 {"type": "remove_body", "step": 35, "id": 9},
 {"type": "add_body", "step": 40, "body": {"id": 500, "type": "dynamic", "mass": 1,
   "shape": {"type": "box", "half_extents": [0.5, 0.5, 0.5]}, "position": [0, 8, 0]}}]}
]=])
set(scene --scene cube-pile --n 100 --steps 80 --inputs ${inputs})
execute_process(COMMAND ${SODA} run ${scene} --territories 1 OUTPUT_VARIABLE one RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "soda run ${scene} --territories 1 failed (${rc}):\n${one}")
endif()
hash_of(reference "${one}")
ranked_run(inputs)
ranked_run(inputs_spec --anticipation 8)
message(STATUS "cube-pile 100 with 6 inputs: one territory ${reference}; 3 territories on 2 ranks: the same")

# --record over ranks: rank 0 writes the replay from every rank's poses;
# its last frame carries the one-territory hash (the mpi_tests compare every
# frame with the threaded recording's).
set(replay ${CMAKE_CURRENT_BINARY_DIR}/mpi_cli_record.replay)
file(REMOVE ${replay})
ranked_run(record --anticipation 8 --record ${replay})
execute_process(COMMAND ${SODA} replay-info ${replay} OUTPUT_VARIABLE info ERROR_VARIABLE err RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR NOT info MATCHES "frames: 81 \\(steps 0 \\.\\. 80\\)" OR
   NOT info MATCHES "last frame: step 80, [0-9]+ bodies, [0-9]+ asleep, state_hash ${reference}")
  message(FATAL_ERROR "the replay recorded on 2 ranks: expected 81 frames ending on ${reference} (${rc}):\n${info}\n${err}")
endif()
message(STATUS "--record on 2 ranks: 81 frames, the last frame's hash ${reference}")

# --checkpoint and --resume over ranks: rank 0 writes, at step 37 (after
# the removal, before the addition), the file the threaded run writes, byte
# for byte; resumed from it over the ranks and on threads, the run ends on
# the one-territory hash.
set(ckpt_ranks ${CMAKE_CURRENT_BINARY_DIR}/mpi_cli_ranks.checkpoint)
set(ckpt_threads ${CMAKE_CURRENT_BINARY_DIR}/mpi_cli_threads.checkpoint)
file(REMOVE ${ckpt_ranks} ${ckpt_threads})
ranked_run(checkpointed --anticipation 8 --checkpoint-at 37 --checkpoint ${ckpt_ranks})
execute_process(COMMAND ${SODA} run ${scene} --territories 3 --checkpoint-at 37 --checkpoint ${ckpt_threads}
                OUTPUT_VARIABLE out RESULT_VARIABLE rc)
if(NOT rc EQUAL 0 OR NOT EXISTS ${ckpt_ranks})
  message(FATAL_ERROR "--checkpoint-at 37 on threads (${rc}) or on 2 ranks failed:\n${out}")
endif()
file(SHA256 ${ckpt_ranks} on_ranks)
file(SHA256 ${ckpt_threads} on_threads)
if(NOT on_ranks STREQUAL on_threads)
  message(FATAL_ERROR "the checkpoint written on 2 ranks differs from the threaded run's")
endif()
foreach(launch "${MPIEXEC};--oversubscribe;-np;2" "")
  execute_process(COMMAND ${launch} ${SODA} run --resume ${ckpt_ranks} --territories 3 --anticipation 8
                  OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 120)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${launch} soda run --resume failed (${rc}):\n${out}\n${err}")
  endif()
  expect_once("state_hash" "${out}" "--resume (${launch})")
  hash_of(resumed "${out}")
  if(NOT resumed STREQUAL reference OR NOT out MATCHES "resumed .* at step 37, ran to step 80")
    message(FATAL_ERROR "resumed (${launch}): state_hash ${resumed}, one territory ${reference}:\n${out}")
  endif()
endforeach()
message(STATUS "--checkpoint-at 37 on 2 ranks: the threaded run's file; resumed on 2 ranks and on threads: ${reference}")

# `soda bench` under mpirun: the tested run (3 territories) on 2 ranks, the
# stock baseline and the one-territory run on rank 0 alone; rank 0 prints
# one table, its JSON has a ratio against the baseline and the K run's hash
# equals the one-territory run's (sleeping on and off); exit 0. Another
# command (not run, not bench) is refused with exit 2.
set(bench_json ${CMAKE_CURRENT_BINARY_DIR}/mpi_cli_bench.json)
file(REMOVE ${bench_json})
execute_process(COMMAND ${MPIEXEC} --oversubscribe -np 2 ${SODA} bench --scene falling-cubes --n 120 --steps 30
                        --territories 3 --repeat 2 --json ${bench_json}
                OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 120)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "mpirun -np 2 soda bench failed (${rc}):\n${out}\n${err}")
endif()
expect_once("state hash, 3 territories vs 1: identical" "${out}" "soda bench on 2 ranks, its table")
file(READ ${bench_json} j)
string(JSON equal GET "${j}" state_hash_equals_one_territory)
string(JSON equal_awake GET "${j}" state_hash_equals_one_territory_awake)
string(JSON ratio GET "${j}" ratio_vs_baseline)
string(JSON ranks LENGTH "${j}" ranks)
if(NOT equal OR NOT equal_awake OR NOT ranks EQUAL 2 OR NOT ratio GREATER 0)
  message(FATAL_ERROR "soda bench on 2 ranks: JSON equal ${equal}/${equal_awake}, ranks ${ranks}, ratio ${ratio}:\n${j}")
endif()
message(STATUS "soda bench on 2 ranks: ratio vs stock ${ratio}, hashes equal to one territory")
execute_process(COMMAND ${MPIEXEC} --oversubscribe -np 2 ${SODA} scenes
                OUTPUT_VARIABLE out ERROR_VARIABLE err RESULT_VARIABLE rc TIMEOUT 60)
if(NOT rc EQUAL 2 OR NOT err MATCHES "only `soda run` and `soda bench`")
  message(FATAL_ERROR "soda scenes under mpirun: expected exit 2 naming run and bench, got ${rc}:\n${out}\n${err}")
endif()
