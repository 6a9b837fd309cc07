"""Request -> core inputs, core result -> response body: one module per resource.

``robot``: a request's ``robot`` (a registered name or an inline URDF) to a model.
``joint``: ``/v1/trajectories/joint`` and ``/v1/trajectories/spline``.
``cartesian``: ``/v1/trajectories/cartesian`` and ``/v1/compare``.
"""
