# The simulator of a --singular proximal solver (tests/simulate/extreme/parallelogram.urdf)
# started on its change point (docs/simulation.md, "Failures").  With the default
# --singular-damping 1e-10 the start's solve is the damped one: counted on the last stdout
# line (near_singular=1, regularized_used=0) and said on stderr with the time and the loop's
# joints.  With --singular-damping 0 the regularized answer at the start is used, counted
# (regularized_used=1) and said on stderr.  The non-proximal fourbar_sim, far from any rank
# loss, says regularized=0 and near_singular=0.  cmake -DSIM=exe -DSIM0=fourbar_sim -P this.
macro(expect cond what)
  cmake_language(EVAL CODE "if(NOT (${cond}))\n message(FATAL_ERROR [==[${what}]==])\nendif()")
endmacro()
set(h 1.5707963267948966)
execute_process(COMMAND "${SIM}" --t-end 0.2 --q0 ${h},-${h},${h} --v0 1,-1,1
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
expect("rc EQUAL 0" "exit ${rc}: ${err}")
expect("out MATCHES \"regularized=0 regularized_used=0 near_singular=1 \"" "last stdout line: '${out}'")
expect("err MATCHES \"note: solves near a rank loss of the loop constraints: 1, answered by the damped solve [(]--singular-damping 1e-10; first at t = 0: constraint row .*joints 'crank_joint'\""
       "no note naming the time and the loop on stderr: '${err}'")
execute_process(COMMAND "${SIM}" --t-end 0.2 --q0 ${h},-${h},${h} --v0 1,-1,1 --singular-damping 0
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
expect("rc EQUAL 0" "--singular-damping 0: exit ${rc}: ${err}")
expect("out MATCHES \"regularized=[1-9][0-9]* regularized_used=1 near_singular=0 \"" "--singular-damping 0: last stdout line: '${out}'")
expect("err MATCHES \"note: accepted states on a singular configuration: 1, answered by the regularized solve [(]first at t = 0: forward dynamics regularized .*joints 'crank_joint'\""
       "--singular-damping 0: no note naming the time and the loop on stderr: '${err}'")
expect("NOT err MATCHES \"damped\"" "--singular-damping 0 stderr: '${err}'")
execute_process(COMMAND "${SIM0}" --t-end 0.1 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
expect("rc EQUAL 0" "fourbar_sim exit ${rc}: ${err}")
expect("out MATCHES \"regularized=0 regularized_used=0 near_singular=0 \"" "fourbar_sim last line: '${out}'")
expect("NOT err MATCHES \"regularized|damped\"" "fourbar_sim stderr: '${err}'")
execute_process(COMMAND "${SIM0}" --t-end 0.1 --singular-damping -1 RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
expect("rc EQUAL 2" "--singular-damping -1: exit ${rc}")
expect("err MATCHES \"--singular-damping must be in [[]0, 1[)]\"" "--singular-damping -1 stderr: '${err}'")
