//! Shape estimation: ordered centerline, smoothing spline, bands and circular-arc fit from a carved cloud (issue 5; not yet built).
