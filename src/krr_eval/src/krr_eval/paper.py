"""The paper's reference numbers (Sec. IV), in one place: what the experiments compare with.

Only numbers the paper reports (its tables, its Figure 4 dialog, its new-circumstances rates);
our settings and defaults are in krr_eval.context.
"""


# Table I, Table II, the new-circumstances rates
PAPER_TABLE1 = {  # br: {condition: (reward, fulfilled, QA cost)}
    0.1: {"outdated": (182.07, 0.851, 20.86), "learned": (206.21, 0.932, 18.73)},
    0.5: {"outdated": (30.54, 0.853, 20.84), "learned": (58.44, 0.927, 18.98)},
    0.7: {"outdated": (-40.33, 0.847, 20.94), "learned": (-14.50, 0.905, 20.56)},
}
PAPER_TABLE1_P = {0.1: 0.028, 0.5: 0.035, 0.7: 0.049}  # reward, 100 random trials each
PAPER_TABLE2 = {  # br: {room: (mean, std, max)}
    0.1: {"room1": (0.274, 0.090, 0.419), "room2": (0.221, 0.075, 0.334),
          "room5": (0.177, 0.063, 0.269)},
    0.5: {"room1": (0.154, 0.056, 0.233), "room2": (0.111, 0.044, 0.176),
          "room5": (0.100, 0.041, 0.156)},
    0.7: {"room1": (0.132, 0.050, 0.207), "room2": (0.104, 0.042, 0.166),
          "room5": (0.100, 0.041, 0.156)},
}
PAPER_NEW_CIRCUMSTANCES = {"baseline": 0.268, "merged": 0.838}

# The robot's questions in the paper's Figure 4 dialog (Sec. IV, "An Illustrative Trial"):
# "Which item is it?", "Should I deliver a coke?", "Should I deliver to office2?".
PAPER_QUESTIONS = ["ask_item", "confirm_item_coke", "confirm_room_room2"]
PAPER_GOAL = {"item": "coke", "person": "bob", "room": "room2"}
