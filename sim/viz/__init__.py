"""Drawing: the GL backend, replay of run logs into frames, compositing, video and plots."""
