"""Built-in wsgrasp grippers, registered through the `wsgrasp` entry-point group."""
