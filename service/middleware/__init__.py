"""HTTP plumbing around the app: body limit, timeouts, metrics, logs, request ids, the catch-all
500, and the uvicorn HTTP protocol. Kept free of imports so each module can be loaded alone."""
