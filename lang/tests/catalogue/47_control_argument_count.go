// Control structures called with the wrong number of arguments.
package ControlCount

var D1 Quadcopter

func INIT() {
	WaitUntil(D1.Z() > 1)
	If(D1.Z() > 1, SEQ_A, SEQ_A, SEQ_A)
	PauseFor()
}

func SEQ_A() {
	D1.Land()
}
