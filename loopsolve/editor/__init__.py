"""The local editor behind ``loopsolve edit`` (DESIGN.md, "Editor").

A designer drags joints of a kinematic diagram in the browser, the linkage is re-solved by
loopsolve's own solver in the assembly mode it was in, and the analysis panels follow. The
layer sits above ``output`` (it reuses the interactive page's data and drawing) and below
``cli``:

* :mod:`~loopsolve.editor.editing`: edits of a kinematic-diagram model ``dict`` (move a joint,
  typed dimensions, add and delete links, joints, sliders and points, masses and loads), each
  giving a new ``dict``; the drawn pose is re-posed at the current input so that the file it
  saves is always consistent;
* :mod:`~loopsolve.editor.analysis`: what the page shows for a model (the sweep's page data,
  transmission angles, Grashof classes, limit positions, forces);
* :mod:`~loopsolve.editor.document`: the edited document (the model, undo/redo, its file);
* :mod:`~loopsolve.editor.synthpanel`: the synthesis methods of the page (path generation with
  free timing, Freudenstein) and how a certified design becomes a diagram;
* :mod:`~loopsolve.editor.jobs`: bounded work in worker processes (a time limit per request,
  background syntheses with progress that can be cancelled);
* :mod:`~loopsolve.editor.server`: the web application (Starlette on uvicorn, loopback only,
  a per-session token, Host and Origin checked) and :mod:`~loopsolve.editor.page`, its page.

Only :mod:`~loopsolve.editor.server` needs the ``edit`` extra (starlette, uvicorn).
"""
