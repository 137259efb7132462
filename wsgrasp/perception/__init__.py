"""Scene processing: cloud I/O, view merging, downsampling, object frame, sampling."""
