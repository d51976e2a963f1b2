/* The analog sensor law file (law.h) over controllers/kernel/ctl_sensor.c,
 * for Tachometer.fmu and CurrentSensor.fmu: the FMU's parameters are
 * ctl_sensor_params' doubles in order, its input the true value, its output
 * the measured one (0 before the first sample), its state a ctl_sensor_state. */
#include "ctl_sensor.h"

static int no_reading(double *out) {
    out[0] = 0.0;
    return CTL_OK;
}

#define LAW_PARAMS ctl_sensor_params
#define LAW_STATE ctl_sensor_state
#define LAW_CHECK ctl_sensor_check
#define LAW_CHECK_STATE ctl_sensor_check_state
#define LAW_FIELD_NAME ctl_sensor_field_name
#define LAW_RESET ctl_sensor_reset
#define LAW_INITIAL(p, out) no_reading(out)
#define LAW_SAMPLE(p, s, in, out) ctl_sensor_sample(p, s, (in)[0], &(out)[0])
#include "law_struct.h"
