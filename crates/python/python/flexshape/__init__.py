"""flexshape: real-time 3-D shape sensing of flexible manipulators from calibrated cameras.

Track a recording, or frames from your own cameras, and get each frame's centerline as an
``(N, 3)`` NumPy array in the rig's world frame (millimetres), with a status that says whether
the shape explains every image (``ok``) or why not::

    import flexshape

    flexshape.simulate("rec", frames=10)            # a recording of the simulated rig
    for record in flexshape.iter_track("rec"):      # each record as soon as it is made
        print(record.frame, record.status, record.tip)

Your own cameras: ``tracker = flexshape.Tracker(rig, backgrounds)`` then
``record = tracker.process([image0, image1, image2])`` per frame (RGB ``uint8`` arrays of
shape ``(height, width, 3)``, in the rig's camera order).

A rig's cameras as OpenCV has them: ``cam = rig["cam0"]`` gives ``cam.K``, ``cam.D``, ``cam.R``,
``cam.t`` (mm) and ``cam.image_size``. Records pickle (for multiprocessing) and rebuild from
their JSON (``flexshape.Record(line)``).

Conventions: millimetres and radians; OpenCV camera conventions (x_cam = R·X_world + t,
distortion k1, k2, p1, p2, k3, pixel (0, 0) the centre of the top-left pixel). Records are
the JSON Lines records of ``flexshape track`` (``Record.to_dict()``), documented in the
repository's docs/formats.md.
"""

from ._flexshape import (
    Calibration,
    Camera,
    FlexshapeError,
    ModelFit,
    Pose,
    Record,
    Rig,
    SimFrame,
    Simulator,
    TrackIter,
    Tracker,
    __version__,
    calibrate,
    fit_model,
    iter_track,
    model_template,
    read_records,
    simulate,
    track,
)

__all__ = [
    "Calibration",
    "Camera",
    "FlexshapeError",
    "ModelFit",
    "Pose",
    "Record",
    "Rig",
    "SimFrame",
    "Simulator",
    "TrackIter",
    "Tracker",
    "__version__",
    "calibrate",
    "fit_model",
    "iter_track",
    "model_template",
    "read_records",
    "simulate",
    "track",
]
