"""Pydantic request/response models, one module per resource; units and bounds live in Field."""
