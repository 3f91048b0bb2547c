"""``lfd-track teach``: a teaching station in the browser (laptop or phone) on the teaching loop.

- :mod:`lfd_track.web.contract` — what the web app drives: :class:`TeachingSession` (a
  ``typing.Protocol``), the lease, the view and the status fields.
- :mod:`lfd_track.web.session` — :class:`LoopSession`, the contract's implementation as an
  arrangement of the one teaching loop (a browser commander fed by the server, observers that
  publish the annotated view and status).
- :mod:`lfd_track.web.app` — the ASGI app (Starlette): the page, ``/api/status``, the WebSocket
  for commands, heartbeats, frames and status; token and host checks; one controlling client.
- :mod:`lfd_track.web.server` — ``lfd-track teach``: builds the session, serves it with uvicorn.
"""
