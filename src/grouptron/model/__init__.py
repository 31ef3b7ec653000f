"""The Trajectron++ CVAE and Grouptron's group- and scene-level encoders."""
