//! Voxel carving: lookup-table and hierarchical shape-from-silhouette over a working volume (issue 4; not yet built).
