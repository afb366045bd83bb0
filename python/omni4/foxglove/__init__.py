"""omni4.foxglove: the robot in Foxglove, live (omni4-bridge, a Foxglove WebSocket server fed
from LCM) and from logs (omni4-mcap, LCM event logs to MCAP), with the model's prediction beside
the encoders' velocity. Topics and schemas: docs/design.md, "Foxglove topics"."""
