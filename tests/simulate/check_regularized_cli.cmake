# The simulator of a --singular proximal solver (tests/simulate/extreme/parallelogram.urdf)
# started on its change point (docs/simulation.md, "Failures"): the regularized answer at
# the start is used, counted on the last stdout line (regularized_used=1) and said on
# stderr with the time and the loop's joints; the non-proximal fourbar_sim says
# regularized=0.  cmake -DSIM=exe -DSIM0=fourbar_sim -P this.
macro(expect cond what)
  cmake_language(EVAL CODE "if(NOT (${cond}))\n message(FATAL_ERROR [==[${what}]==])\nendif()")
endmacro()
set(h 1.5707963267948966)
execute_process(COMMAND "${SIM}" --t-end 0.2 --q0 ${h},-${h},${h} --v0 1,-1,1
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
expect("rc EQUAL 0" "exit ${rc}: ${err}")
expect("out MATCHES \"regularized=[1-9][0-9]* regularized_used=1 \"" "last stdout line: '${out}'")
expect("err MATCHES \"note: accepted states on a singular configuration: 1, answered by the regularized solve [(]first at t = 0: forward dynamics regularized .*joints 'crank_joint'\""
       "no note naming the time and the loop on stderr: '${err}'")
execute_process(COMMAND "${SIM0}" --t-end 0.1 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
expect("rc EQUAL 0" "fourbar_sim exit ${rc}: ${err}")
expect("out MATCHES \"regularized=0 regularized_used=0 \"" "fourbar_sim last line: '${out}'")
expect("NOT err MATCHES \"regularized\"" "fourbar_sim stderr: '${err}'")
