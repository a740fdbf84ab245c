"""``morf eval``: trained avatars scored on frames they never trained on, beside the RGB floor.

``runs.py`` which runs and floors, ``targets.py`` which frames, ``frames.py`` those frames through a
run's camera at the evaluation resolution, ``views.py`` the frames and y-t columns kept for the
images, ``sheet.py`` the comparison sheet and y-t slice image, ``project_eval.py`` the whole.
"""
