"""The model files shipped with stewart-pin, installed as ``stewart_pin.model_files``.

``package.xml`` (makes this folder the ROS-style package ``stewart_pin_models`` that the
xacro include finds) and ``urdf/``: the xacro sources ``stewart.urdf.xacro`` and
``stewart_leg.xacro``, and for each preset the URDF, its loop-closure sidecar, the MJCF,
the description (TOML) and the xacro arguments, written by ``scripts/generate_models.py``.
Read them with :func:`stewart_pin.formats.robot_files.model_files`. No code here.
"""
