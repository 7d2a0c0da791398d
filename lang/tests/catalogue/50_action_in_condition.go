// A condition reads properties; it cannot run an action.
package ActionCondition

var D1 Quadcopter

func INIT() {
	If(D1.Land(), SEQ_Done)
}

func SEQ_Done() {
	D1.Disarm()
}
