"""What the commands do, as functions for Python: evaluate a checkpoint on any source
(:mod:`.evaluate`), train a run (:mod:`.train`). ``grouptron`` commands parse their options,
call one of these and print."""
