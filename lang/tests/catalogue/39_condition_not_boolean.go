// A condition must be a boolean.
package NumberCondition

var D1 Quadcopter

func INIT() {
	If(D1.Battery(), SEQ_Fly)
	PauseUntil(3)
}

func SEQ_Fly() {
	D1.FlyByX(1)
}
