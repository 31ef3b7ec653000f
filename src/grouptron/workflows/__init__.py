"""What the commands do, as functions for Python: evaluate a checkpoint on any source
(:mod:`.evaluate`), train a run (:mod:`.train`), adapt one to a site (:mod:`.adapt`), forecast
a track file (:mod:`.predict`), draw its forecasts (:mod:`.plot`), size prediction regions
(:mod:`.calibrate`), detect and score groups (:mod:`.groups`), the benchmark report
(:mod:`.report`) and counts (:mod:`.data`). ``grouptron`` commands parse their options, call
one of these and print."""
