"""``POST /v1/batch``: many plan requests in one body, each answered by its own endpoint in process
(``endpoints``: the table, ``subrequest``: one in-process call, ``run``: budget, admission, order)."""
