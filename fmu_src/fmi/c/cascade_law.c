/* The cascade law file (law.h) over controllers/kernel/ctl_cascade.c: the
 * FMU's parameters are ctl_cascade_params' doubles in order, its inputs
 * position_setpoint, velocity_setpoint, position, speed and current, its output
 * u, its state a ctl_cascade_state. */
#include "ctl_cascade.h"

#define LAW_PARAMS ctl_cascade_params
#define LAW_STATE ctl_cascade_state
#define LAW_CHECK ctl_cascade_check
#define LAW_CHECK_STATE ctl_cascade_check_state
#define LAW_FIELD_NAME ctl_cascade_field_name
#define LAW_RESET ctl_cascade_reset
#define LAW_INITIAL(p, out) ctl_cascade_initial_output(p, &(out)[0])
#define LAW_SAMPLE(p, s, in, out) ctl_cascade_sample(p, s, (in)[0], (in)[1], (in)[2], (in)[3], (in)[4], &(out)[0])
#include "law_struct.h"
