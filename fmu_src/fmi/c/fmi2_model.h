/* The model contract (fmi_model.h) under the FMI 2.0 names a model file may
 * use: fmi2Status and its values, fmi2Real, fmi2ValueReference, ...  They are
 * the contract's neutral types by other names, not the FMI 2.0 headers' own, so
 * a model file that includes this header (and not the FMI headers) compiles
 * unchanged behind either adapter, fmi2_wrapper.c or fmi3_wrapper.c.
 */
#ifndef GRB_FMI2_MODEL_H
#define GRB_FMI2_MODEL_H

#include "fmi_model.h"

#ifdef fmi2TypesPlatform_h
#error "fmi2_model.h is for model files: an adapter includes fmi_model.h beside the FMI headers"
#endif

typedef grb_fmi_status fmi2Status;
#define fmi2OK GRB_FMI_OK
#define fmi2Warning GRB_FMI_WARNING
#define fmi2Discard GRB_FMI_DISCARD
#define fmi2Error GRB_FMI_ERROR
#define fmi2Fatal GRB_FMI_FATAL

typedef grb_value_reference fmi2ValueReference;
typedef double fmi2Real;
typedef int fmi2Integer;
typedef int fmi2Boolean;
typedef const char *fmi2String;
#define fmi2True 1
#define fmi2False 0

#endif
