"""Many runs at once: sweeps of scripted episodes or policy episodes over scenario or env
settings, and diagnoses of many measurement sets, one Ray task per run, on this machine or a
Ray cluster, into results folders that resume where they stopped."""
