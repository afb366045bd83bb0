"""docs/foxglove-layout.json, built with foxglove-sdk's layout types: the robot in 3D (body and
wheels on the camera pose), commanded vs measured (encoders) vs predicted (model) velocity per
axis with the difference, currents per motor, each motor's resistance in use and its online
estimate (OMNI4_ADAPT), mode and faults, and health.

    python -m omni4.foxglove.layout > docs/foxglove-layout.json
(python/tests/test_foxglove_model.py checks that the file is this output and that every topic
it plots is one the bridge and omni4-mcap write.)"""
import json
import sys

import omni4

from . import topics

AXES = (("v", 0, "m/s"), ("vn", 1, "m/s"), ("w", 2, "rad/s"))
COLORS = {"commanded": "#9e9e9e", "measured": "#1f77b4", "predicted": "#ff7f0e",
          "difference": "#d62728"}
WINDOW_S = 10.0  # [s] plots follow the last 10 s


def resistance_plot(fl, series):
    """Each motor's R in use (solid) and online estimate (dashed) from OMNI4_ADAPT, over the
    whole run (a winding heats over minutes)."""
    return fl.PlotPanel(title="motor R [ohm]: in use (solid), estimate (dashed)",
                        config=fl.PlotConfig(
        paths=[series(f"{omni4.CHANNEL_ADAPT}.{field}[{j}]", f"R_{j} {what}", c, **kw)
               for field, what, kw in (("R", "in use", {}),
                                       ("R_estimate", "estimate", {"line_style": "dashed"}))
               for j, c in enumerate(("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd"))],
        show_legend=True, legend_display="floating", y_axis_label="R [ohm]"))


def build():
    import foxglove.layouts as fl

    def series(value, label, color, **kw):
        return fl.PlotSeries(value=value, label=label, color=color, enabled=True,
                             timestamp_method="receiveTime", **kw)

    def velocity_plot(axis, idx, unit):
        v = topics.TOPIC_VELOCITY
        return fl.PlotPanel(title=f"{axis} [{unit}]: commanded, measured, predicted", config=fl.PlotConfig(
            paths=[
                series(f"{omni4.CHANNEL_CMD}{{mode_name==\"VELOCITY\"}}.velocity[{idx}]",
                       "commanded", COLORS["commanded"]),
                series(f"{v}.encoder.{axis}", "measured (encoders)", COLORS["measured"]),
                series(f"{v}.predicted.{axis}", "predicted (model)", COLORS["predicted"]),
                series(f"{v}.difference.{axis}", "measured - predicted", COLORS["difference"]),
            ],
            show_legend=True, legend_display="floating", following_view_width=WINDOW_S,
            y_axis_label=f"{axis} [{unit}]"))

    currents = fl.PlotPanel(title="currents [A]", config=fl.PlotConfig(
        paths=[series(f"{omni4.CHANNEL_MOTORS}.current[{j}]", f"motor {j}", c)
               for j, c in enumerate(("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd"))],
        show_legend=True, legend_display="floating", following_view_width=WINDOW_S,
        y_axis_label="current [A]"))
    voltages = fl.PlotPanel(title="applied voltages [V]", config=fl.PlotConfig(
        paths=[series(f"{omni4.CHANNEL_MOTORS}.voltage[{j}]", f"motor {j}", c)
               for j, c in enumerate(("#1f77b4", "#ff7f0e", "#2ca02c", "#9467bd"))],
        show_legend=True, legend_display="floating", following_view_width=WINDOW_S,
        y_axis_label="voltage [V]"))
    resistance = resistance_plot(fl, series)
    states = fl.StateTransitionsPanel(title="mode and faults", config=fl.StateTransitionsConfig(
        paths=[fl.StateTransitionsSeries(value=f"{omni4.CHANNEL_MOTORS}.mode_name", label="mode",
                                         timestamp_method="receiveTime"),
               fl.StateTransitionsSeries(value=f"{omni4.CHANNEL_MOTORS}.faults",
                                         label="faults (bits)", timestamp_method="receiveTime"),
               fl.StateTransitionsSeries(value=f"{omni4.CHANNEL_EXPERIMENT}.kind",
                                         label="experiment", timestamp_method="receiveTime")],
        show_legend=True))
    health = fl.RawMessagesPanel(title="health: loop rate, overruns, dropped, rejected",
                                 config=fl.RawMessagesConfig(topic_path=topics.TOPIC_HEALTH))
    faults = fl.RawMessagesPanel(title="fault names",
                                 config=fl.RawMessagesConfig(
                                     topic_path=f"{omni4.CHANNEL_MOTORS}.fault_names"))
    scene = fl.ThreeDeePanel(title="robot (camera pose)", config=fl.ThreeDeeConfig(
        follow_tf=topics.WORLD_FRAME, fixed_frame=topics.WORLD_FRAME,
        topics={topics.TOPIC_SCENE: fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                topics.TOPIC_POSE: fl.BaseRendererPoseTopicSettings(visible=True)},
        layers={"grid": fl.BaseRendererGridLayerSettings(visible=True)}))

    def split(direction, *items):
        return fl.SplitContainer(direction=direction, items=[
            fl.SplitItem(proportion=p, content=c) for p, c in items])

    top = split("row", (2, scene),
                (3, split("column", *((1, velocity_plot(*a)) for a in AXES))))
    bottom = split("row", (1, currents), (1, voltages), (1, resistance), (1, states),
                   (1, split("column", (2, health), (1, faults))))
    return fl.Layout(content=split("column", (3, top), (2, bottom)))


def layout_json():
    return json.dumps(json.loads(build().to_json()), indent=2) + "\n"


def main():
    sys.stdout.write(layout_json())
    return 0


if __name__ == "__main__":
    sys.exit(main())
