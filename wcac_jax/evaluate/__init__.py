"""A finished run's policies evaluated outside the project's own compiled program:
`numpy_policy` computes a trained policy's deterministic action in numpy."""
