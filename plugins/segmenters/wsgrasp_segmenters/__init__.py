"""Built-in wsgrasp segmenters, registered through the `wsgrasp` entry-point group."""
