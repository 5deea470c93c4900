# examples/batch_mpi over MPI ranks and threads gives the same bytes as the
# serial run (1 rank, a plain loop): issue 21 item 5.
#   cmake -DEXE=jrgen_batch_mpi -DMPIEXEC=mpirun -DMPIFLAGS=--allow-run-as-root,--oversubscribe -DWORK=dir -P this
file(MAKE_DIRECTORY "${WORK}")
string(REPLACE "," ";" MPIFLAGS "${MPIFLAGS}")
set(runs 100)  # 3 ranks get uneven blocks (33, 33, 34)
set(nan_run 40)  # this run fails (NaN in v0): reported in its line, the others go on

# batch(<name> <np> <program arguments>...): runs the example under mpirun, output ${WORK}/<name>.csv.
function(batch name np)
  execute_process(COMMAND "${MPIEXEC}" -np ${np} ${MPIFLAGS} "${EXE}" --runs ${runs} --t-end 1.5
                          --nan-run ${nan_run} --output "${WORK}/${name}.csv" ${ARGN}
                  RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "${name}: mpirun -np ${np} exited ${rc}\n${out}\n${err}")
  endif()
  message(STATUS "${name}: ${out}")
  if(NOT out MATCHES "runs=${runs} failed=1 ")
    message(FATAL_ERROR "${name}: unexpected summary (only run ${nan_run} should fail): ${out}")
  endif()
endfunction()

batch(serial 1 --serial)
file(STRINGS "${WORK}/serial.csv" lines)
list(LENGTH lines n)
if(NOT n EQUAL 101)
  message(FATAL_ERROR "serial.csv has ${n} lines, expected a header and ${runs} runs")
endif()
math(EXPR line "${nan_run} + 1")
list(GET lines ${line} failed)
if(NOT failed MATCHES "^${nan_run},1,0,,,,,,,,,,0,0,0,\"at t = 0: .*non-finite")
  message(FATAL_ERROR "serial.csv: run ${nan_run} is not reported as failed at t = 0 (non-finite): ${failed}")
endif()
list(GET lines 100 last)
if(NOT last MATCHES "^99,0,")
  message(FATAL_ERROR "serial.csv: last line is not run 99 with status 0: ${last}")
endif()

foreach(cfg "np2_t2;2;2" "np2_t1;2;1" "np1_t4;1;4" "np3_t2;3;2")
  list(GET cfg 0 name)
  list(GET cfg 1 np)
  list(GET cfg 2 threads)
  batch(${name} ${np} --threads ${threads})
  execute_process(COMMAND "${CMAKE_COMMAND}" -E compare_files "${WORK}/serial.csv" "${WORK}/${name}.csv"
                  RESULT_VARIABLE differ)
  if(NOT differ EQUAL 0)
    message(FATAL_ERROR "${name}.csv (${np} ranks, ${threads} threads) differs from serial.csv (1 rank, plain loop)")
  endif()
endforeach()
