"""Visualisation: the robot in meshcat (live or as a standalone HTML animation; 6-UPS
robots from their URDF, general three-joint legs by :class:`LegScene`; a payload on the
platform by :mod:`.payload_scene`) and matplotlib figures of simulated motions.

Optional dependencies (``pip install stewart-pin[viz]``): meshcat for the viewer,
matplotlib for the figures; each is imported where it is used.
"""

from stewart_pin.viz.leg_scene import LegScene, general_robot
from stewart_pin.viz.plots import (
    actuator_work,
    plot_energy,
    plot_energy_balance,
    plot_forces,
    plot_lengths,
    plot_tracking_error,
    reference_poses,
    save_figures,
)
from stewart_pin.viz.viewer import CameraView, Viewer, tree_configuration, visual_model

__all__ = [
    "CameraView",
    "LegScene",
    "Viewer",
    "actuator_work",
    "general_robot",
    "plot_energy",
    "plot_energy_balance",
    "plot_forces",
    "plot_lengths",
    "plot_tracking_error",
    "reference_poses",
    "save_figures",
    "tree_configuration",
    "visual_model",
]
