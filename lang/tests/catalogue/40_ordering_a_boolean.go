// `<` and friends order numbers; a boolean property is not ordered.
package OrderBool

var D1 Quadcopter

func INIT() {
	WaitUntil(D1.IsArmed() < 1, SEQ_Go)
}

func SEQ_Go() {
	D1.Takeoff(1)
}
