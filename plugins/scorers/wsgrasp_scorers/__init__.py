"""Built-in wsgrasp scorers, registered through the `wsgrasp` entry-point group."""
