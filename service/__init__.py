"""HTTP layer of Trajectory Service: schemas, routes, error mapping. No planning math lives here."""

__version__ = "0.1.0"
