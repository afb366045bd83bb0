/* scenario_adapt.h - the online resistance estimation's scenario (scenario_adapt.c) on the
 * scenarios' robot (the accessors of scenario_goal.h). */
#ifndef OMNI4_SCENARIO_ADAPT_H
#define OMNI4_SCENARIO_ADAPT_H

#include "scenario_goal.h"

/* Warm windings (the plant's R_j 4-20 % above the model's) under 12 s of changing VELOCITY
 * commands: the line "adapt ok|FAILED" with the R_j in use, their worst relative error against
 * the plant's over the last 6 s (bound 3 %) and the acceptances and reverts. 0 if it passed. */
int scenario_adapt(void);

#endif /* OMNI4_SCENARIO_ADAPT_H */
