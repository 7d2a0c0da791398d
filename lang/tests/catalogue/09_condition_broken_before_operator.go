// A condition split over lines must break after `&&`, as in Go: here the
// line ends before it, so Go ends the statement in the middle of the call.
package BrokenCondition

var D1 Quadcopter

func INIT() {
	RepeatWhile(D1.X() > -30
		&& D1.X() < 30, SEQ_Body)
}

func SEQ_Body() {
	D1.FlyByX(1)
}
