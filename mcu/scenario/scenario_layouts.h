/* scenario_layouts.h - the controller on a three-wheel robot and a four at unequal angles and
 * distances (scenario_layouts.c), on the scenarios' robot (the accessors of scenario_goal.h). */
#ifndef OMNI4_SCENARIO_LAYOUTS_H
#define OMNI4_SCENARIO_LAYOUTS_H

#include "scenario_goal.h"

/* Three wheels at 0/120/240 deg and a RoboCup-style four at 60/135/225/300 deg, each holding
 * the paper's tracking scenario's two velocities on the plant of its layout: the lines
 * "tracking_3_wheels ok|FAILED", "tracking_4_unequal ok|FAILED" with the rms tracking error (and
 * slot 3 of the three wheels never driven), and each one's controller cost per tick. The number
 * that failed. */
int scenario_layouts(void);

#endif /* OMNI4_SCENARIO_LAYOUTS_H */
