/* The PID law file (law.h) over controllers/kernel/ctl_pid.c: the FMU's
 * parameters are ctl_pid_params' doubles in order, its inputs setpoint,
 * measurement and feedforward, its output u, its state a ctl_pid_state. */
#include "ctl_pid.h"

#define LAW_PARAMS ctl_pid_params
#define LAW_STATE ctl_pid_state
#define LAW_CHECK ctl_pid_check
#define LAW_CHECK_STATE ctl_pid_check_state
#define LAW_FIELD_NAME ctl_pid_field_name
#define LAW_RESET(p, s) ctl_pid_reset(p, 0.0, s)
#define LAW_INITIAL(p, out) ctl_pid_initial_output(p, &(out)[0])
#define LAW_SAMPLE(p, s, in, out) ctl_pid_sample(p, s, (in)[0], (in)[1], (in)[2], &(out)[0])
#include "law_struct.h"
