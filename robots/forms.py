from django import forms

from robots.choices import OperatorActionKind


class RobotActionForm(forms.Form):
    """An operator's button on the robot page: Pause, Resume or Return to dock."""

    action = forms.ChoiceField(choices=OperatorActionKind.choices)
