# The simulator built by add_jr_simulator() for models/fourbar.urdf (nq = nv = 3,
# nc = 2), run as docs/interface.md section 7 says.  cmake -DSIM=exe -DWORK=dir -P this.
file(MAKE_DIRECTORY "${WORK}")
set(csv "${WORK}/run.csv")

# expect("<if() condition>" "message"): fails the test with the message when
# the condition (evaluated as written) is false.
macro(expect cond what)
  cmake_language(EVAL CODE "if(NOT (${cond}))\n message(FATAL_ERROR [==[${what}]==])\nendif()")
endmacro()

# 1. A run with rows every 0.1 s: header, 6 rows (t = 0, 0.1, ..., 0.5), last line.
execute_process(COMMAND "${SIM}" --t-end 0.5 --q0 0.3,0,0 --v0 2,0,0 --output "${csv}" --every 0.1
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
expect("rc EQUAL 0" "exit ${rc}: ${err}")
expect("err MATCHES \"note: --q0 does not close the loops; assembled\"" "no assembly note on stderr: '${err}'")
file(STRINGS "${csv}" rows)
list(GET rows 0 header)
expect("header STREQUAL \"t,q0,q1,q2,v0,v1,v2,energy,phi_norm,phiqv_norm\"" "header '${header}'")
list(LENGTH rows n)
expect("n EQUAL 7" "${n} lines in the CSV, expected the header and 6 rows")
list(GET rows 1 first)
list(GET rows 6 last)
expect("first MATCHES \"^0,\"" "first row '${first}' not at t = 0")
expect("last MATCHES \"^0.5,\"" "last row '${last}' not at t = 0.5")
string(REPLACE "," ";" fields "${last}")
list(LENGTH fields nf)
expect("nf EQUAL 10" "last row has ${nf} fields: '${last}'")
list(GET fields 8 phi)
expect("phi LESS_EQUAL 1e-12" "phi_norm ${phi} at t = 0.5")
string(STRIP "${out}" out)
string(REGEX REPLACE ".*\n" "" line "${out}")
expect("line MATCHES \"^t=0.5 steps=[1-9][0-9]* rejected=[0-9]+ fd_calls=[1-9][0-9]* .*cpu_s=[0-9.]+$\"" "last stdout line '${line}'")

# 2. Every accepted step when --every is not given; rk4 with --dt 0.01: 50 steps, 51 rows.
execute_process(COMMAND "${SIM}" --t-end 0.5 --v0 2,0,0 --integrator rk4 --dt 0.01 --output "${csv}"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
expect("rc EQUAL 0" "rk4: exit ${rc}: ${err}")
expect("err STREQUAL \"\"" "rk4 from the assembled default q0 wrote '${err}' on stderr")
file(STRINGS "${csv}" rows)
list(LENGTH rows n)
expect("n EQUAL 52" "rk4 --dt 0.01: ${n} lines, expected 52")
expect("out MATCHES \"steps=50 \"" "rk4 --dt 0.01: '${out}'")
expect("out MATCHES \" err_est=[0-9.]+e-0[5-9] err_step_max=[0-9.e+-]+ \"" "rk4 --dt 0.01: err_est: '${out}'")

# 2b. rk4 with too long a step says so on stderr (docs/simulation.md, "Fixed steps: err_est"):
# --dt 0.2 over 2 s ends with the energy 1.83 J against 2.67 J (measured err_est 0.68); exit 0.
execute_process(COMMAND "${SIM}" --t-end 2 --v0 2,0,0 --integrator rk4 --dt 0.2
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
expect("rc EQUAL 0" "rk4 --dt 0.2: exit ${rc}: ${err}")
expect("err MATCHES \"^fourbar_sim: warning: rk4 with --dt 0.2: estimated error [0-9.]+e-01 .*docs/simulation.md.\n$\"" "rk4 --dt 0.2: stderr '${err}'")
expect("out MATCHES \" err_est=[0-9.]+e-01 \"" "rk4 --dt 0.2: '${out}'")

# 3. Errors: one line on stderr, exit status 2 for a bad command line (docs/cli.md).
foreach(case "--q0;1,2" "--v0;0,nan,0" "--integrator;euler" "--rtol;-1")
  execute_process(COMMAND "${SIM}" --t-end 1 ${case} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  expect("rc EQUAL 2" "'${case}' exited ${rc}, expected 2")
  string(REGEX MATCHALL "\n" newlines "${err}")
  list(LENGTH newlines lines)
  expect("lines EQUAL 1" "'${case}': stderr is not one line: '${err}'")
  expect("err MATCHES \"^fourbar_sim: error: \"" "'${case}': '${err}'")
endforeach()
execute_process(COMMAND "${SIM}" --t-end 1 --q0 1,2 ERROR_VARIABLE err)
expect("err MATCHES \"--q0: 2 values given, the model has nq = 3\"" "bad --q0 message: '${err}'")

# 4. A failure of the generated solver during the run: the time and the joint,
#    exit status 1, and no CSV written (none created; an earlier one unchanged;
#    no temporary file left).
file(REMOVE "${csv}")
execute_process(COMMAND "${SIM}" --t-end 1 --v0 1e200,0,0 --output "${csv}"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
expect("rc EQUAL 1" "--v0 1e200,0,0 exited ${rc}, expected 1")
expect("NOT EXISTS \"${csv}\"" "a failed run left ${csv}")
file(WRITE "${csv}" "earlier\n")
execute_process(COMMAND "${SIM}" --t-end 1 --v0 1e200,0,0 --output "${csv}" RESULT_VARIABLE rc2)
file(READ "${csv}" earlier)
expect("rc2 EQUAL 1 AND earlier STREQUAL \"earlier\n\"" "a failed run (exit ${rc2}) changed the earlier CSV: '${earlier}'")
file(GLOB leftovers "${WORK}/*partial*")
expect("leftovers STREQUAL \"\"" "temporary files left: ${leftovers}")
expect("err MATCHES \"^fourbar_sim: error: at t = 0: forward dynamics status 3: .*joint 'joint_A'\"" "overflow: '${err}'")
string(REGEX MATCHALL "\n" newlines "${err}")
list(LENGTH newlines lines)
expect("lines EQUAL 1" "overflow: stderr is not one line: '${err}'")

# 5. Messages that say what to do (issue 22 item 5): each bad command line
#    gives one line naming the fix.  (Patterns are regular expressions: '.'
#    stands for the parentheses, which would need double escapes here.)
foreach(case
    "--t-end;1;--frobnicate;1|unknown option '--frobnicate'; the options are --t-end, --q0"
    "--t-end;1;--q;1|unknown option '--q'"
    "--t-end;1;--integrator=rk4|write '--integrator rk4' .the value follows a space"
    "--t-end;1;--q0|--q0: missing value; write --q0 a,b,"
    "--q0;0,0,0|missing --t-end T: give the end time in seconds .> 0., e.g. --t-end 1"
    "--t-end;-1|--t-end must be positive"
    "--t-end;1;--integrator;euler|'euler' is not auto, radau5, sdirk4, dopri5 or rk4; use one of these"
    "--t-end;1;--q0;1,2|--q0: 2 values given, the model has nq = 3; give 3 numbers separated by commas"
    "--t-end;1;--output;${WORK}/no_such_folder/run.csv|cannot write: No such file or directory; create its folder first")
  string(FIND "${case}" "|" bar)
  string(SUBSTRING "${case}" 0 ${bar} args)
  math(EXPR bar "${bar} + 1")
  string(SUBSTRING "${case}" ${bar} -1 pattern)
  execute_process(COMMAND "${SIM}" ${args} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  expect("rc EQUAL 2" "'${args}' exited ${rc}, expected 2")
  string(REGEX MATCHALL "\n" newlines "${err}")
  list(LENGTH newlines lines)
  expect("lines EQUAL 1" "'${args}': stderr is not one line: '${err}'")
  expect("err MATCHES \"${pattern}\"" "'${args}': '${err}' does not match '${pattern}'")
endforeach()
