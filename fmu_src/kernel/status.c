/* What each grb_status means, in words a log or an error message can carry. */
#include "grubler.h"

const char *grb_status_message(grb_status status) {
    switch (status) {
    case GRB_OK: return "no error";
    case GRB_SINGULAR: return "the mass matrix or the constraint Jacobian is singular";
    case GRB_NONFINITE_DERIVATIVE: return "the state derivative is not finite";
    case GRB_STEP_UNDERFLOW: return "the step size fell below its limit";
    case GRB_TOO_MANY_STEPS: return "too many internal steps";
    case GRB_NONFINITE_FIXED_STEP: return "a fixed step gave a non-finite state";
    case GRB_BRANCH_JUMP: return "the projection would remove too much of the joint speeds (a change point, where "
                                 "two assembly branches meet)";
    case GRB_BAD_ARGUMENT: return "a time, tolerance or size is out of range";
    case GRB_NOT_CLOSED: return "the loop cannot be closed";
    }
    return "unknown kernel status";
}
